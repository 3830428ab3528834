"""The figures of ``rrr4 optimize``: the phase plane with the limit curves, the efforts
against their limits, and the contact-condition margin along the path."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from .base import save_figure

__all__ = ["optimal_figures"]


def optimal_figures(opt, out: Path) -> list[Path]:
    """phase_plane.png (a time law) or task_path.png (a point-to-point motion), efforts.png and
    contact_margin.png (only with the contact condition) of an
    :class:`rrr4.results.optimal.Optimization` into `out`."""
    law, curves = opt.law, opt.curves
    files = [_phase_plane(opt, out)] if curves is not None else [_task_path(opt, out)]
    what = "with the contact condition" if law.contact else "actuator limits"
    kind = "law" if curves is not None else "motion"

    fig, ax = plt.subplots(figsize=(8, 4.5))
    units = dict(zip(opt.problem.model.actuator_names, opt.problem.effort_units, strict=True))
    for i, name in enumerate(law.actuator_names):
        line, = ax.plot(law.t, law.efforts[:, i], lw=1.3, label=f"{name} [{units[name]}]")
        ax.axhline(law.torque_limit[i], color=line.get_color(), ls=":", lw=0.8)
        ax.axhline(-law.torque_limit[i], color=line.get_color(), ls=":", lw=0.8)
    ax.plot([], [], color="0.4", ls=":", label="limits (+-)")
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("actuator effort [N m or N]")
    ax.set_title(f"efforts of the optimal {kind} ({what}, ideal model)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    files.append(save_figure(fig, out / "efforts.png", dpi=120))

    if law.contact:
        fig, ax = plt.subplots(figsize=(8, 4))
        margin = law.axial - law.f_min
        for j, name in enumerate(law.joint_names):
            ax.plot(law.t, margin[:, j], lw=1, label=name)
        ax.plot(law.t, margin.min(axis=1), color="k", lw=2, label="smallest")
        ax.axhline(0.0, color="tab:red", ls="--", lw=1, label="f_min reached")
        ax.set_xlabel("time t [s]")
        ax.set_ylabel("contact-condition margin [N]")
        ax.set_title(f"axial load of each passive joint above f_min = {law.f_min:g} N (ideal model, "
                     f"sign {law.sign:+d})")
        ax.set_yscale("symlog", linthresh=1.0)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=5)
        files.append(save_figure(fig, out / "contact_margin.png", dpi=120))
    return files


def _phase_plane(opt, out: Path) -> Path:
    """s_dot over s: the limit curves, the optimum with the contact condition and without."""
    law, free, curves = opt.law, opt.limits_only, opt.curves
    what = "with the contact condition" if law.contact else "actuator limits"
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for name, style in (("actuator limits", dict(color="0.55", ls="--")),
                        ("actuator limits and contact", dict(color="tab:red", ls="--"))):
        if name in curves:
            ax.plot(curves["s"], curves[name], lw=1.2, label=f"limit curve: {name}", **style)
    if free is not None:
        ax.plot(free.s, free.s_dot, color="0.3", lw=1.5, label=f"optimum, actuator limits only ({free.duration:.4g} s)")
    ax.plot(law.s, law.s_dot, color="tab:blue", lw=2, label=f"optimum, {what} ({law.duration:.4g} s)")
    ax.set_xlabel("path progress s [-]")
    ax.set_ylabel("path speed ds/dt [1/s]")
    ax.set_title(f"{opt.problem.name}: phase plane of the time law ({law.objective})")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower center")
    return save_figure(fig, out / "phase_plane.png", dpi=120)


def _task_path(opt, out: Path) -> Path:
    """The task point's path of a point-to-point motion (and of the one with actuator limits
    only), against the straight line, with the Jacobian's condition number along it."""
    law, free = opt.law, opt.limits_only
    fig, ax = plt.subplots(figsize=(6.5, 5.5))
    mm = 1e3
    ax.plot([law.start[0] * mm, law.target[0] * mm], [law.start[1] * mm, law.target[1] * mm], color="0.6", ls="--",
            lw=1, label="straight line")
    if free is not None:
        ax.plot(free.pose[:, 0] * mm, free.pose[:, 1] * mm, color="0.3", lw=1.2, marker=".", ms=3,
                label=f"actuator limits only ({free.duration:.4g} s)")
    sc = ax.scatter(law.pose[:, 0] * mm, law.pose[:, 1] * mm, c=law.condition, cmap="viridis", s=14, zorder=3)
    what = "with the contact condition" if law.contact else "actuator limits"
    ax.plot(law.pose[:, 0] * mm, law.pose[:, 1] * mm, color="tab:blue", lw=1.5, label=f"optimum, {what} "
            f"({law.duration:.4g} s)")
    ax.plot(*(np.array(law.start[:2]) * mm), "ks", label="start")
    ax.plot(*(np.array(law.target[:2]) * mm), "k*", ms=10, label="target")
    fig.colorbar(sc, ax=ax, label="condition number of J [-]")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(f"{opt.problem.name}: optimal motion of the task point ({law.objective})")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return save_figure(fig, out / "task_path.png", dpi=120)

"""Figures of a study (matplotlib, Agg). Each function writes one PNG and returns its path.

Arms are drawn in fixed colours (:data:`rrr4.results.figures.base.STYLE`): with preload
blue, without preload orange; for a driven scene, with clearance red and the ideal twin black.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ..study import Study
from .base import STYLE, save_figure

__all__ = ["driver_window", "orbits", "contact_forces", "platform_error", "torques", "preload_alpha",
           "body_accelerations", "driver_efforts", "all_figures"]

DPI = 110


def _grid(count: int, width: float = 3.2, height: float = 2.6):
    cols = min(count, 4)
    rows = math.ceil(count / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(width * cols, height * rows + 0.6), squeeze=False)
    return fig, axes.ravel()


def _suptitle(fig, text: str) -> None:
    """Figure title wrapped to the figure's width."""
    fig.suptitle(textwrap.fill(text, width=max(int(fig.get_figwidth() * 13), 30)))


def _finish(fig, axes, used: int, title: str, path: Path, legend_kw: dict | None = None) -> Path:
    """Hide the unused panels of a grid, legend on the first, title, layout, save."""
    for ax in axes[used:]:
        ax.set_visible(False)
    axes[0].legend(**(legend_kw or {"fontsize": 7}))
    _suptitle(fig, title)
    fig.tight_layout()
    return save_figure(fig, path, dpi=DPI)


def _title(study: Study, what: str) -> str:
    return f"{study.scene.name}: {what}"


def _clearance_joints(study: Study) -> tuple[str, ...]:
    return max((a.simulation.clearance_joints for a in study.arms.values()), key=len)


def orbits(study: Study, path: Path) -> Path | None:
    """Journal-centre orbit (eccentricity [um]) inside the clearance circle, every clearance joint."""
    joints = _clearance_joints(study)
    if not joints:
        return None
    fig, axes = _grid(len(joints), 3.0, 3.0)
    for k, name in enumerate(joints):
        ax = axes[k]
        c = study.scene.joint(name).radial_clearance * 1e6
        phi = np.linspace(0, 2 * np.pi, 361)
        ax.plot(c * np.cos(phi), c * np.sin(phi), color="0.3", lw=1.0, label="clearance circle")
        for arm_name, arm in reversed(study.arms.items()):  # the preloaded orbit is short: draw it last, thick
            if name not in arm.simulation.clearance_joints:
                continue
            e = arm.simulation.eccentricity[:, k, :] * 1e6
            ax.plot(e[:, 0], e[:, 1], lw=2.5 if arm_name == "with_preload" else 0.6, **STYLE[arm_name])
        ax.set_aspect("equal")
        lim = 1.15 * c
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_title(name)
        ax.set_xlabel("e_x [um]")
        ax.set_ylabel("e_y [um]")
    return _finish(fig, axes, len(joints), _title(study, "journal-centre orbits inside the clearance circle "
                                                         "(global frame)"), path, {"loc": "center", "fontsize": 7})


def contact_forces(study: Study, path: Path) -> Path | None:
    """Normal contact force [N] at every clearance joint (the ideal twin: the magnitude of its
    pin reaction), against time, or for a driven scene against the driver angle over two
    revolutions after the start transient."""
    joints = _clearance_joints(study)
    if not joints:
        return None
    if "ideal" in study.arms:
        x_of, x_label, x_lim = driver_window(study)
    else:
        x_of, x_label, x_lim = (lambda sim: sim.t), "t [s]", (0.0, study.t_end)
    fig, axes = _grid(len(joints), 3.6 if len(joints) > 1 else 8.0, 2.4 if len(joints) > 1 else 3.6)
    f_min = study.preload.f_min if study.preload is not None else None
    for k, name in enumerate(joints):
        ax = axes[k]
        for arm_name, arm in study.arms.items():
            sim = arm.simulation
            x = x_of(sim)
            keep = (x >= x_lim[0]) & (x <= x_lim[1])
            if name in sim.clearance_joints:
                k_j = sim.clearance_joints.index(name)
                f = sim.normal_force[:, k_j]
                ax.plot(x[keep], f[keep], lw=0.5, **STYLE[arm_name])
                film = np.linalg.norm(sim.film_force[:, k_j], axis=1) if sim.film_force is not None else f * 0
                if film.any():  # a lubricated joint: the oil film's force beside the dry contact's
                    ax.plot(x[keep], film[keep], lw=0.8, ls="--", color=STYLE[arm_name].get("color"),
                            label=f"{STYLE[arm_name].get('label', arm_name)}: oil film |F|")
            elif name in sim.ideal_passive_joints:
                r = np.linalg.norm(sim.reaction[:, sim.ideal_passive_joints.index(name)], axis=1)
                ax.plot(x[keep], r[keep], lw=1.0, **STYLE[arm_name])
        if f_min:
            ax.axhline(f_min, color="k", ls="--", lw=0.8, label=f"f_min = {f_min:g} N")
        ax.set_yscale("symlog", linthresh=1.0)
        ax.set_ylim(bottom=0.0)
        ax.set_xlim(*x_lim)
        ax.set_title(name)
        ax.set_xlabel(x_label)
        ax.set_ylabel("normal force [N]")
    lubricated = any(a.simulation.film_force is not None and a.simulation.film_force.any()
                     for a in study.arms.values())
    what = ("dry contact and oil-film (dashed) force at each clearance joint" if lubricated else
            "normal contact force at each clearance joint (0 = free flight)")
    return _finish(fig, axes, len(joints), _title(study, what), path)


def platform_error(study: Study, path: Path) -> Path | None:
    """The task's position error |p - p_ref| [um] against time (scenes with a task body or point)."""
    if study.problem.model.task is None:
        return None
    fig, ax = plt.subplots(figsize=(8, 3.6))
    for arm_name, arm in study.arms.items():
        sim = arm.simulation
        rms = np.sqrt(np.mean(sim.platform_error**2)) * 1e6
        ax.plot(sim.t, sim.platform_error * 1e6, lw=0.7, color=STYLE[arm_name]["color"],
                label=f"{STYLE[arm_name]['label']} (RMS {rms:.3g} um)")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("position error [um]")
    ax.set_title(_title(study, f"{study.problem.model.task_label} position error against the commanded path"))
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, path, dpi=DPI)


def torques(study: Study, path: Path) -> Path | None:
    """Actuator efforts (torques [N m], forces [N]) against time, every arm, with their
    feed-forward references."""
    model = study.problem.model
    names = model.actuator_names
    n = len(names)
    if n == 0 or model.task is None:
        return None
    fig, axes = _grid(n, 4.0, 2.6)
    for i in range(n):
        ax = axes[i]
        for arm_name, arm in study.arms.items():
            sim = arm.simulation
            ax.plot(sim.t, sim.tau[:, i], lw=0.6, **STYLE[arm_name])
        ax.plot(study.t_path, study.tau_min_norm[:, i], "k:", lw=1.0, label="minimum-norm feed-forward")
        if study.preload is not None:
            ax.plot(study.preload.t, study.preload.tau[:, i], "k--", lw=0.8, label="preload feed-forward")
        ax.set_title(f"actuator {names[i]}")
        ax.set_xlabel("t [s]")
        unit = study.problem.effort_units[i]
        ax.set_ylabel(f"{'torque' if unit == 'N m' else 'force'} [{unit}]")
        ax.set_xlim(0, study.t_end)
    return _finish(fig, axes, n, _title(study, "actuator torques (feed-forward + PD)"), path)


def preload_alpha(study: Study, path: Path) -> Path | None:
    """Null-space coordinate alpha(t) [N m, or N with prismatic actuators] and the smallest
    reaction margin [N]."""
    sol = study.preload
    if sol is None:
        return None
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    alpha = np.asarray(sol.alpha).reshape(len(sol.t), -1)
    for k in range(alpha.shape[1]):
        a1.plot(sol.t, alpha[:, k], lw=1.0, label=f"alpha{'' if alpha.shape[1] == 1 else k + 1} ({sol.method})")
    a1.set_ylabel(f"alpha [{study.problem.effort_unit}]")
    a1.set_title(_title(study, f"preload along the null space, tau = tau_p + alpha n ({sol.method})"))
    a1.legend()
    a1.grid(alpha=0.3)
    norms = sol.reaction_magnitudes
    a2.plot(sol.t, norms.min(axis=1), lw=1.0, label="smallest |r_j| over B1..C4")
    a2.axhline(sol.f_min, color="k", ls="--", lw=0.8, label=f"f_min = {sol.f_min:g} N")
    bad = ~sol.feasible
    if bad.any():
        a2.plot(sol.t[bad], norms.min(axis=1)[bad], "rx", ms=3, label="infeasible sample")
    a2.set_ylim(0.0, 1.5 * max(float(norms.min(axis=1).max()), sol.f_min))
    a2.set_xlabel("t [s]")
    a2.set_ylabel("smallest reaction [N]")
    a2.legend()
    a2.grid(alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, path, dpi=DPI)


def driver_window(study: Study) -> tuple:
    """(x values for a simulation, x label, x limits): the first driver's angle [deg] (its
    travel from ``initial_deg``, in the direction it turns) over two revolutions after the
    first (the start transient), or over the run when it is shorter than three; time when
    there is no revolute driver at a constant speed."""
    d = study.scene.graph.drivers[0] if study.scene.graph.drivers else None
    if d is None or study.scene.graph.joint(d.joint).type != "revolute" or d.speed == 0 or d.time_law != "constant":
        return (lambda sim: sim.t), "t [s]", (0.0, study.t_end)
    start = np.degrees(d.initial)
    travel = np.degrees(abs(d.speed) * study.t_end)
    lo, hi = (start + 360.0, start + 1080.0) if travel >= 3 * 360.0 else (start, start + min(travel, 720.0))
    return (lambda sim: start + np.degrees(abs(d.speed) * sim.t)), f"{d.name} angle [deg]", (lo, hi)


def body_accelerations(study: Study, path: Path) -> Path | None:
    """Driven scenes: centre-of-mass acceleration components [m/s^2] of every body, with
    clearance and ideal, over two driver revolutions after the start transient (components
    that stay zero in every arm are left out; None when no centre of mass accelerates)."""
    if "ideal" not in study.arms:
        return None
    model = study.problem.model
    x_of, x_label, x_lim = driver_window(study)
    panels = [(b, c) for b in model.body_names for c in (0, 1)
              if any(np.max(np.abs(a.simulation.qdd[:, model.coordinates(b)][:, c])) > 1e-9
                     for a in study.arms.values())]
    if not panels:
        return None
    fig, axes = _grid(len(panels), 4.0, 2.6)
    for ax, (b, c) in zip(axes, panels, strict=False):
        for arm_name, arm in study.arms.items():
            sim = arm.simulation
            x = x_of(sim)
            keep = (x >= x_lim[0]) & (x <= x_lim[1])
            ax.plot(x[keep], sim.qdd[keep][:, model.coordinates(b)][:, c], lw=0.5 if arm_name != "ideal" else 1.2,
                    **STYLE[arm_name])
        ax.set_xlim(*x_lim)
        ax.set_title(f"{b}: {'xy'[c]} acceleration")
        ax.set_xlabel(x_label)
        ax.set_ylabel(f"a_{'xy'[c]} [m/s^2]")
    return _finish(fig, axes, len(panels),
                   _title(study, "centre-of-mass accelerations, clearance against ideal joints"), path)


def driver_efforts(study: Study, path: Path) -> Path | None:
    """Driven scenes: the effort each driver applies [N m or N] against time."""
    drivers = study.scene.graph.drivers
    if "ideal" not in study.arms or not drivers:
        return None
    fig, axes = _grid(len(drivers), 6.0, 3.0)
    for k, d in enumerate(drivers):
        unit = study.problem.model.effort_unit(d.joint)
        for arm_name, arm in study.arms.items():
            sim = arm.simulation
            axes[k].plot(sim.t, sim.driver_effort[:, k], lw=0.5 if arm_name != "ideal" else 1.2, **STYLE[arm_name])
        axes[k].set_title(f"driver {d.name} on joint {d.joint}")
        axes[k].set_xlabel("t [s]")
        axes[k].set_ylabel(f"effort [{unit}]")
        axes[k].legend(fontsize=7)
    _suptitle(fig, _title(study, "driver effort, clearance against ideal joints"))
    fig.tight_layout()
    return save_figure(fig, path, dpi=DPI)


def all_figures(study: Study, out: Path) -> list[Path]:
    """Write every figure that applies to the study into `out`; returns the files written."""
    made = [orbits(study, out / "orbits.png"), contact_forces(study, out / "contact_force.png"),
            platform_error(study, out / "platform_error.png"), torques(study, out / "torques.png"),
            preload_alpha(study, out / "preload_alpha.png"), body_accelerations(study, out / "accelerations.png"),
            driver_efforts(study, out / "driver_effort.png")]
    return [p for p in made if p is not None]

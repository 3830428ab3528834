"""The figures of a wear study (``rrr4 wear``): every joint's wear profile after N cycles
(each bore to scale, the wear magnified), and how the worn volume, the platform error and
the contact losses evolve with the cycles."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ...contact.wear import depth_at
from .base import STYLE, save_figure

__all__ = ["plot_wear_profiles", "plot_wear_history"]

_SURFACE = {"bearing": "-", "journal": ":"}


def _magnification(deepest: float, radius: float) -> float:
    """A round factor (1, 2 or 5 times a power of ten) that draws the deepest wear [m] as about
    a fifth of the radius [m]; 1 when nothing wore."""
    if deepest <= 0:
        return 1.0
    raw = 0.2 * radius / deepest
    power = 10.0 ** math.floor(math.log10(raw))
    return max(f * power for f in (1.0, 2.0, 5.0) if f * power <= raw)


def plot_wear_profiles(study, path: Path) -> Path:
    """One axis per worn joint, drawn to scale [mm] in the bearing body's frame: the original
    bore (grey circle; the journal's surface inside it when the journal wears) and each arm's
    worn surface with the wear magnified by M (written in the arm's colour): the bore grows outward by M w(psi),
    the journal shrinks inward by M w(psi) (its angle in the journal's own frame). An arrow
    marks the load direction of the arm's last cycle (where the journal presses the bore)."""
    arms = list(study.arms.values())
    joints = arms[0].joints
    cols = min(4, len(joints))
    rows = math.ceil(len(joints) / cols)
    fig, axes = plt.subplots(rows, cols, squeeze=False, figsize=(max(3.4 * cols, 8.0), 3.9 * rows + 1.3))
    a = np.linspace(0.0, 2 * math.pi, 721)
    for n, (ax, j) in enumerate(zip(axes.flat, joints, strict=False)):
        spec = study.scene.graph.joint(j)
        radius = {"bearing": spec.bearing_radius, "journal": spec.journal_radius}
        ax.plot(spec.bearing_radius * 1e3 * np.cos(a), spec.bearing_radius * 1e3 * np.sin(a), color="0.6", lw=2.5,
                label="original bore")
        if any("journal" in arm.profiles[j] for arm in arms):
            ax.plot(spec.journal_radius * 1e3 * np.cos(a), spec.journal_radius * 1e3 * np.sin(a), ":", color="0.6",
                    lw=2.0, label="original journal")
        for k, arm in enumerate(arms):
            color = STYLE[arm.name]["color"]
            deepest = max(float(np.max(depth_at(c, a))) for c in arm.profiles[j].values())
            M = _magnification(deepest, spec.bearing_radius)  # each arm its own factor, written in its colour
            for s, c in arm.profiles[j].items():
                r = (radius[s] + (1.0 if s == "bearing" else -1.0) * M * depth_at(c, a)) * 1e3
                ax.plot(r * np.cos(a), r * np.sin(a), _SURFACE[s], color=color, lw=1.4,
                        label=f"{STYLE[arm.name]['label']}, worn {s}")
            ax.text(0.0, 1.02 + 0.075 * (len(arms) - 1 - k), f"x{M:g}: deepest {deepest * 1e6:.3g} um", color=color,
                    fontsize=7, transform=ax.transAxes, va="bottom")
            load = arm.records[-1].get("load_direction_deg", [None] * len(joints))[joints.index(j)]
            if load is not None:
                u = np.array([math.cos(math.radians(load)), math.sin(math.radians(load))])
                ax.annotate("", xy=0.8 * spec.journal_radius * 1e3 * u, xytext=(0, 0),
                            arrowprops={"arrowstyle": "-|>", "color": color, "lw": 1.6})
        ax.set_aspect("equal")
        lim = spec.bearing_radius * 1e3 * 1.35
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_title(j, fontsize=10, loc="right")
        if n // cols == rows - 1 or n + cols >= len(joints):
            ax.set_xlabel("x [mm], bearing body's frame", fontsize=8)
        if n % cols == 0:
            ax.set_ylabel("y [mm]", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.2)
    for ax in list(axes.flat)[len(joints):]:
        ax.set_visible(False)
    handles, labels = axes.flat[0].get_legend_handles_labels()
    handles.append(plt.Line2D([], [], color="k", marker=r"$\rightarrow$", ls="", ms=10))
    labels.append("load direction (last cycle)")
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 3), fontsize=8)
    fig.suptitle(f"{study.scene.name}: worn surfaces after {study.cycles:.3g} cycles, to scale [mm]\n(the wear "
                 "magnified by the factor written in each arm's colour)", fontsize=10)
    fig.tight_layout(rect=(0, 0.12, 1, 0.94))
    fig.subplots_adjust(hspace=0.35)
    return save_figure(fig, path, dpi=110)


def plot_wear_history(study, path: Path) -> Path:
    """Against the cycles: the worn volume of every joint [mm^3] (thin) and their sum (thick),
    the platform position error of the cycle (RMS and max [um]) and its contact losses."""
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    task = study.scene.graph.task is not None
    for arm in study.arms.values():
        c, label, n = STYLE[arm.name]["color"], STYLE[arm.name]["label"], arm.cycles
        volume = arm.series("volume_m3") * 1e9
        axes[0].plot(n, volume, color=c, lw=0.6, alpha=0.5)
        axes[0].plot(n, volume.sum(axis=1), "o-", color=c, lw=1.8, ms=3, label=f"{label}, all joints")
        if task:
            axes[1].plot(n, arm.series("platform_error_rms_m") * 1e6, "o-", color=c, ms=3, label=f"{label}, RMS")
            axes[1].plot(n, arm.series("platform_error_max_m") * 1e6, "s--", color=c, ms=3, label=f"{label}, max")
        axes[2].plot(n, arm.series("contact_loss_events"), "o-", color=c, ms=3, label=label)
    axes[0].set_ylabel("worn volume [mm^3] (thin: each joint)")
    axes[1].set_ylabel("platform position error in the cycle [um]")
    axes[2].set_ylabel("contact losses in the cycle (all joints)")
    if not task:
        axes[1].text(0.5, 0.5, "no task body", ha="center", transform=axes[1].transAxes)
    for ax in axes:
        ax.set_xlabel("cycles (markers: the cycles simulated)")
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
    fig.suptitle(f"{study.scene.name}: {study.cycles:.3g} cycles by cycle jumping (at most "
                 f"{study.max_change:g} clearances per jump)", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path, dpi=110)

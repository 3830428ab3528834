"""The figures of a wear study (``rrr4 wear``): every joint's wear profile after N cycles
(polar), and how the worn volume, the platform error and the contact losses evolve with the
cycles."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ...contact.wear import depth_at
from .base import STYLE, save_figure

__all__ = ["plot_wear_profiles", "plot_wear_history"]

_SURFACE = {"bearing": "-", "journal": ":"}


def plot_wear_profiles(study, path: Path) -> Path:
    """One polar axis per worn joint: depth [um] over the bearing angle (bearing: solid,
    journal: dotted; the angle in that surface's body frame), one colour per arm."""
    arms = list(study.arms.values())
    joints = arms[0].joints
    cols = min(4, len(joints))
    rows = math.ceil(len(joints) / cols)
    fig, axes = plt.subplots(rows, cols, subplot_kw={"projection": "polar"}, squeeze=False,
                             figsize=(max(3.2 * cols, 8.0), 3.4 * rows + 0.8))
    a = np.linspace(0.0, 2 * math.pi, 721)
    top = max(float(np.max(depth_at(c, a))) for arm in arms for by in arm.profiles.values() for c in by.values()) * 1e6
    for ax, j in zip(axes.flat, joints, strict=False):
        for arm in arms:
            for s, c in arm.profiles[j].items():
                ax.plot(a, depth_at(c, a) * 1e6, _SURFACE[s], color=STYLE[arm.name]["color"], lw=1.3,
                        label=f"{STYLE[arm.name]['label']}, {s}")
        ax.set_ylim(0, top * 1.05 if top > 0 else 1)
        ax.set_title(j, fontsize=10)
        ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[len(joints):]:
        ax.set_visible(False)
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 4), fontsize=8)
    fig.suptitle(f"{study.scene.name}: wear depth [um] over the bearing angle after {study.cycles:.3g} cycles",
                 fontsize=10)
    fig.tight_layout(rect=(0, 0.06, 1, 0.96))
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

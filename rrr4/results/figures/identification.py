"""The figures of an identification (:func:`rrr4.identify`): what the identified model
explains against what was measured, the residuals, and the parameters' correlation."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from .base import save_figure

__all__ = ["plot_identification_fit", "plot_identification_residuals", "plot_correlation"]

# column -> (label, unit, factor to the unit)
_UNITS = {"x_m": ("x", "um", 1e6), "y_m": ("y", "um", 1e6), "theta_rad": ("orientation", "urad", 1e6)}


def _unit(c: str):
    if c in _UNITS:
        return _UNITS[c]
    if c.endswith(("_x_m", "_y_m")):  # a driven scene's body position (its columns B_x_m, B_y_m, B_theta_rad)
        return (c[:-2].replace("_", " "), "mm", 1e3)
    if c.endswith("_theta_rad") and not c.startswith("theta_"):
        return (c.removesuffix("_theta_rad") + " angle", "rad", 1.0)
    if "_effort_" in c:  # a driver's effort D_effort_Nm
        return (c.rsplit("_effort_", 1)[0] + " effort", "mN m" if c.endswith("Nm") else "mN", 1e3)
    if c.startswith("theta_"):
        revolute = c.endswith("_rad")
        return (c.removeprefix("theta_").rsplit("_", 1)[0] + " angle", "urad" if revolute else "um", 1e6)
    return (c.removeprefix("tau_").rsplit("_", 1)[0] + " effort", "mN m" if c.endswith("Nm") else "mN", 1e3)


def plot_identification_fit(ident, path: Path) -> Path:
    """One panel per fitted column: the measured offset from the path (pose), the friction
    effort off the preload direction (efforts, method 'seated') or the column itself (angles
    and efforts, method 'dynamic'), and what the identified model explains."""
    cols = list(ident.residual)
    fig, axes = plt.subplots(len(cols), 1, figsize=(8.5, 1.7 * len(cols) + 0.8), sharex=True, squeeze=False)
    for ax, c in zip(axes[:, 0], cols, strict=True):
        name, unit, f = _unit(c)
        observed = (ident.explained[c] + ident.residual[c]) * f
        ax.plot(ident.t, observed, ".", ms=1.5, color="0.5", label="measured")
        ax.plot(ident.t, ident.explained[c] * f, color="tab:red", lw=1.2, label="identified model")
        what = "offset from path" if c in _UNITS else "from ideal IK" if c.startswith("theta_") else \
            "off preload" if ident.method == "seated" else ""
        ax.set_ylabel(f"{name} {what}\n[{unit}]", fontsize=8)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8, loc="upper right", markerscale=6)
    axes[-1, 0].set_xlabel("time [s]")
    model = "seated model" if ident.method == "seated" else "simulation (shooting)"
    fig.suptitle(f"{ident.scene.name}: measurements and the identified {model} ({ident.fit['samples']} "
                 "instants)", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.98))
    return save_figure(fig, path, dpi=110)


def plot_identification_residuals(ident, path: Path) -> Path:
    """The residuals (measured - identified model) per fitted column, with +-2 noise levels."""
    cols = list(ident.residual)
    fig, axes = plt.subplots(len(cols), 1, figsize=(8.5, 1.5 * len(cols) + 0.8), sharex=True, squeeze=False)
    for ax, c in zip(axes[:, 0], cols, strict=True):
        name, unit, f = _unit(c)
        ax.plot(ident.t, ident.residual[c] * f, lw=0.7, color="tab:blue", label="residual")
        s = ident.noise[c] * f
        how = "estimated" if ident.noise_estimated[c] else "given"
        ax.axhspan(-2 * s, 2 * s, color="tab:orange", alpha=0.2, label=f"+-2 noise std ({how})")
        ax.set_ylabel(f"{name}\n[{unit}]", fontsize=8)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8, loc="upper right")
    axes[-1, 0].set_xlabel("time [s]")
    fig.suptitle(f"{ident.scene.name}: residuals of the identification (reduced chi^2 "
                 f"{ident.fit['reduced_chi2']:.3g})", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.98))
    return save_figure(fig, path, dpi=110)


def plot_correlation(ident, path: Path) -> Path:
    """The parameters' correlation matrix as a heat map with its values."""
    keys = ident.keys
    c = np.asarray(ident.correlation, float)
    size = 2.5 + 0.75 * len(keys)
    fig, ax = plt.subplots(figsize=(size + 2.5, size))
    im = ax.imshow(c, vmin=-1, vmax=1, cmap="RdBu_r")
    for i in range(len(keys)):
        for j in range(len(keys)):
            ax.text(j, i, "-" if not np.isfinite(c[i, j]) else f"{c[i, j]:.2f}", ha="center", va="center",
                    fontsize=7, color="w" if np.isfinite(c[i, j]) and abs(c[i, j]) > 0.6 else "k")
    short = [k.replace("joints.per_joint.", "").replace(".radial_clearance", " clearance")
             .replace("mechanism.chains", "chain").replace("effects.", "") for k in keys]
    ax.set_xticks(range(len(keys)), short, rotation=40, ha="right", fontsize=8)
    ax.set_yticks(range(len(keys)), short, fontsize=8)
    fig.colorbar(im, ax=ax, label="correlation of the estimates [-]")
    verdict = "identifiable" if ident.verdict["identifiable"] else "NOT identifiable (see identification.json)"
    ax.set_title(f"{ident.scene.name}: correlation of the estimates; {verdict}", fontsize=9)
    fig.tight_layout()
    return save_figure(fig, path, dpi=110)

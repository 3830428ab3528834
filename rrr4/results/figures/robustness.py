"""The robustness cases (:func:`rrr4.studies.robustness.robustness`) as one figure."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from .base import STYLE, save_figure

__all__ = ["plot_robustness"]

_MODELS = {"true": "tab:purple", "identified": "tab:red"}  # the compensated controller's other models


def plot_robustness(rows: list[dict], path: Path, title: str = "") -> Path:
    """Grouped bars of the platform RMS error [um] per case, one bar per arm and controller
    model (log scale, in the order of the rows), with the 1 um target line. rows: those of
    :func:`rrr4.studies.robustness.robustness`."""
    cases = list(dict.fromkeys(r["case"] for r in rows))
    series = list(dict.fromkeys((r["arm"], r.get("model", "nominal")) for r in rows))
    fig, ax = plt.subplots(figsize=(9.0 + 1.5 * (len(series) > 2), 4.2))
    width = 0.76 / len(series)
    x = np.arange(len(cases))
    top = 0.0
    for k, (arm, model) in enumerate(series):
        vals = [next(r["platform_error_rms_m"] for r in rows if r["case"] == c and r["arm"] == arm
                     and r.get("model", "nominal") == model) * 1e6 for c in cases]
        top = max(top, *vals)
        color, label = STYLE[arm]["color"], STYLE[arm]["label"]
        if model != "nominal":
            color, label = _MODELS[model], f"{label}, model: {model}"
        elif any(a == arm and m != "nominal" for a, m in series):
            label = f"{label}, model: nominal"
        bars = ax.bar(x + (k - (len(series) - 1) / 2) * width, vals, width, color=color, label=label)
        for b, v in zip(bars, vals, strict=True):
            ax.annotate(f"{v:.2g}", (b.get_x() + b.get_width() / 2, v), ha="center", va="bottom", fontsize=7)
    ax.axhline(1.0, color="k", ls=":", lw=1, label="1 um")
    ax.set_yscale("log")
    ax.set_ylim(top=top * 6)  # room for the legend above the bars
    ax.set_xticks(x, cases, rotation=20, ha="right")
    ax.set_ylabel("platform position error, RMS [um]")
    ax.set_title(title or "controller with the nominal model on a mechanism that differs from it", fontsize=10)
    ax.legend(fontsize=8, ncol=3, loc="upper left")
    ax.grid(axis="y", which="both", alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, path, dpi=110)

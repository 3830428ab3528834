"""Figures of a sweep's results.csv: each metric against each varied key (the arms in one
plot; a case whose arm has not converged, its ``converged`` cell False, drawn hollow), a heat
map over the first two grid keys, and histograms of a Monte Carlo."""

from __future__ import annotations

import csv
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np

from .base import STYLE, save_figure

__all__ = ["sweep_figures", "FIGURE_METRICS", "DRIVEN_FIGURE_METRICS"]

# metric -> (axis label, scale)
FIGURE_METRICS = {"platform_error_rms_m": ("platform error RMS [um]", 1e6),
                  "contact_loss_events": ("contact-loss events, all joints", 1.0),
                  "min_contact_force_N": ("smallest contact force [N]", 1.0)}
# those of a driven scene's sweep (its CSV has no platform error); the first is the heat map's
DRIVEN_FIGURE_METRICS = {"acceleration_deviation_rms_m_s2": ("acceleration deviation RMS [m/s^2]", 1.0),
                         "impacts_per_revolution": ("impacts per revolution", 1.0),
                         "peak_contact_force_N": ("peak contact force [N]", 1.0)}


def _read(csv_path: Path) -> list[dict]:
    with Path(csv_path).open(newline="") as f:
        return [r for r in csv.DictReader(f) if r["status"] == "ok"]


def _converged(row: dict) -> bool:
    """A row's verdict (its `converged` cell; a sweep from before the verdict: True)."""
    return row.get("converged", "True") != "False"


def _values(rows: list[dict], metric: str, scale: float = 1.0, key: str | None = None):
    """(x, y): the `key` column (or zeros) and metric * scale of the rows where the metric
    applies (a metric that does not apply to an arm is an empty cell)."""
    sel = [r for r in rows if r.get(metric, "") != ""]
    x = np.array([float(r[key]) if key else 0.0 for r in sel])
    return x, np.array([float(r[metric]) for r in sel]) * scale


def sweep_figures(csv_path, keys, grid_keys, mc_keys, out_dir, title: str = "") -> list[Path]:
    """Write the figures of a sweep into out_dir; returns their paths. keys: every varied key
    path (CSV columns); grid_keys / mc_keys: those of the grid and of the Monte Carlo."""
    rows = _read(csv_path)
    out_dir = Path(out_dir)
    files: list[Path] = []
    if not rows:
        return files
    arms = list(dict.fromkeys(r["arm"] for r in rows))
    metrics = FIGURE_METRICS if "platform_error_rms_m" in rows[0] else DRIVEN_FIGURE_METRICS
    heat, (heat_label, heat_scale) = next(iter(metrics.items()))
    for metric, (label, scale) in metrics.items():
        cols = min(len(keys), 4)
        nrows = -(-len(keys) // cols)
        fig, axes = plt.subplots(nrows, cols, figsize=(3.8 * cols, 3.0 * nrows + 0.5), squeeze=False)
        for ax in axes.ravel()[len(keys):]:
            ax.axis("off")
        for ax, key in zip(axes.ravel(), keys, strict=False):
            for arm in arms:
                mine = [r for r in rows if r["arm"] == arm]
                for ok in (True, False):  # an unconverged case (its verdict) is drawn hollow
                    x, y = _values([r for r in mine if _converged(r) == ok], metric, scale, key)
                    if y.size:
                        ax.plot(x, y, "o", ms=4, alpha=0.7, color=STYLE[arm]["color"],
                                mfc=STYLE[arm]["color"] if ok else "none",
                                label=STYLE[arm]["label"] + ("" if ok else ", not converged"))
            ax.set_xlabel(key, fontsize=8)
            ax.set_ylabel(label, fontsize=8)
            ax.ticklabel_format(axis="x", useOffset=False, style="sci", scilimits=(-3, 4))
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3)
        axes[0][0].legend(fontsize=7)
        fig.suptitle(f"{title}: {label} against each varied key (every case)", fontsize=10)
        fig.tight_layout()
        files.append(save_figure(fig, out_dir / f"{metric}.png", dpi=110))
    heat_arms = [a for a in arms if _values([r for r in rows if r["arm"] == a], heat)[1].size]
    if len(grid_keys) >= 2 and heat_arms:
        kx, ky = grid_keys[0], grid_keys[1]
        xs = sorted({float(r[kx]) for r in rows})
        ys = sorted({float(r[ky]) for r in rows})
        fig, axes = plt.subplots(1, len(heat_arms), figsize=(4.2 * len(heat_arms), 3.6), squeeze=False)
        for ax, arm in zip(axes[0], heat_arms, strict=True):
            z = np.full((len(ys), len(xs)), np.nan)
            for i, yv in enumerate(ys):
                for j, xv in enumerate(xs):
                    _, v = _values([r for r in rows if r["arm"] == arm and float(r[kx]) == xv
                                    and float(r[ky]) == yv], heat, heat_scale)
                    if v.size:
                        z[i, j] = np.median(v)
            im = ax.imshow(z, origin="lower", aspect="auto", cmap="viridis",
                           norm=matplotlib.colors.LogNorm() if np.nanmin(z) > 0 else None)
            for (i, j), v in np.ndenumerate(z):
                if np.isfinite(v):
                    ax.text(j, i, f"{v:.3g}", ha="center", va="center", fontsize=7, color="w")
            ax.set_xticks(range(len(xs)), [f"{v:g}" for v in xs], fontsize=7)
            ax.set_yticks(range(len(ys)), [f"{v:g}" for v in ys], fontsize=7)
            ax.set_xlabel(kx)
            ax.set_ylabel(ky)
            ax.set_title(STYLE[arm]["label"], fontsize=9)
            fig.colorbar(im, ax=ax, label=f"{heat_label}, median of the other keys")
        fig.suptitle(f"{title}: {heat_label} over {kx} and {ky}", fontsize=10)
        fig.tight_layout()
        files.append(save_figure(fig, out_dir / "heatmap.png", dpi=110))
    if mc_keys:
        fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.4))
        for ax, (metric, (label, scale)) in zip(axes, list(metrics.items())[:2], strict=True):
            vals = {arm: _values([r for r in rows if r["arm"] == arm], metric, scale)[1] for arm in arms}
            vals = {arm: v for arm, v in vals.items() if v.size}
            if vals:
                every = np.concatenate(list(vals.values()))
                bins = np.linspace(every.min() - 0.5 * scale * (metric == "contact_loss_events"),
                                   every.max() + 1e-12, 40)
            for arm, v in vals.items():
                ax.hist(v, bins=bins, alpha=0.7, color=STYLE[arm]["color"], label=STYLE[arm]["label"])
            ax.set_xlabel(label)
        for ax in axes:
            ax.set_ylabel("cases")
            ax.legend(fontsize=7)
            ax.grid(alpha=0.3)
        n = len({r["case"] for r in rows})
        fig.suptitle(f"{title}: Monte Carlo, {n} samples of {len(mc_keys)} toleranced keys", fontsize=10)
        fig.tight_layout()
        files.append(save_figure(fig, out_dir / "histograms.png", dpi=110))
    return files

"""The workspace maps of a scene (:func:`rrr4.studies.maps.workspace_map`) as one figure."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ...problem import Problem
from ...trajectory import sample_path
from .base import save_figure

__all__ = ["plot_map", "map_labels"]


def map_labels(problem: Problem, orientation: float) -> tuple[str, str]:
    """(what the axes locate, where the map is taken): the task body's centre of mass at the
    path's orientation, or a task point (its body's angle free)."""
    body = problem.model.task
    if problem.model.task_point is not None:
        return f"task point on {body}", f"of the task point on {body} (its angle free)"
    return body, f"at theta = {orientation:g} rad"


def plot_map(m: dict, problem: Problem, path: Path) -> Path:
    """Four heat maps (condition number, smallest transmission (n-RRR only), preload effort at
    rest and under the peak acceleration (N m, or N for prismatic actuators), blank where it
    cannot hold f_min) with the scene's path on top."""
    s = sample_path(problem.path)
    where, at = map_labels(problem, m["orientation"])
    unit = problem.effort_unit
    word = "torque" if unit == "N m" else "effort"
    ext = (m["x"][0] * 1e3, m["x"][-1] * 1e3, m["y"][0] * 1e3, m["y"][-1] * 1e3)
    panels = [("condition", "cond(J) [-] (log10)", np.log10(m["condition"]), "viridis_r"),
              ("min_transmission", "smallest transmission |sin| [-]", m["min_transmission"], "viridis"),
              ("torque_rest_Nm", f"preload {word} at rest, max |tau| [{unit}]",
               np.where(m["feasible_rest"], m["torque_rest_Nm"], np.nan), "magma_r"),
              ("torque_peak_Nm", f"... under the path's peak acceleration ({m['a_peak']:.2g} m/s^2) [{unit}]",
               np.where(m["feasible_peak"], m["torque_peak_Nm"], np.nan), "magma_r")]
    if np.all(np.isnan(m["min_transmission"])):  # a graph: no transmission angle defined
        panels.pop(1)
    fig, axes = plt.subplots(2, 2, figsize=(10.5, 9.0)) if len(panels) == 4 else plt.subplots(1, 3, figsize=(15, 5))
    for ax, (_, label, z, cmap) in zip(axes.ravel(), panels, strict=True):
        im = ax.imshow(z, origin="lower", extent=ext, cmap=cmap, aspect="equal")
        fig.colorbar(im, ax=ax, shrink=0.85, label=label)
        ax.contour(m["x"] * 1e3, m["y"] * 1e3, m["reachable"].astype(float), levels=[0.5], colors="k",
                   linewidths=0.8)
        ax.plot(s.pose[:, 0] * 1e3, s.pose[:, 1] * 1e3, "c-", lw=2, label="the scene's path")
        ax.set_xlabel(f"{where} x [mm]")
        ax.set_ylabel(f"{where} y [mm]")
        ax.set_title(label.split(" [")[0], fontsize=9)
    axes.ravel()[0].legend(fontsize=8, loc="lower right")
    what = "preload" if m["preload"] else "minimum-norm torques (no preload)"
    fig.suptitle(f"{problem.name}: workspace {at}; blank: unreachable, or the {what} "
                 "cannot hold f_min within the limits", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path, dpi=100)

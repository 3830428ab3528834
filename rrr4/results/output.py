"""Result directories, written atomically (:func:`rrr4.files.atomic_directory`): everything
goes into a temporary sibling directory, which replaces the target only when complete. An
interrupted or failed run leaves an earlier result as it was.
"""

from __future__ import annotations

import json
from pathlib import Path

from .. import files
from .animation import MOTION, render, save_motion
from .figures import all_figures
from .study import Study
from .summary import study_summary
from .tables import report_markdown, write_timeseries_csv

__all__ = ["atomic_directory", "write_results", "check_target", "MARKER"]

MARKER = "summary.json"  # a directory holding it is an rrr4 result and may be replaced


def check_target(out: Path) -> None:
    """`out` must be absent, empty, or an earlier result (holds summary.json)."""
    files.check_target(Path(out), MARKER)


def atomic_directory(out, fill) -> Path:
    """:func:`rrr4.files.atomic_directory` for result directories (marker summary.json)."""
    return files.atomic_directory(out, fill, MARKER)


def write_results(study: Study, out, animate: bool = True, progress: bool = False) -> tuple[dict, list[str]]:
    """Write figures, timeseries.csv, summary.json and report.md of `study` into `out`
    atomically, and with `animate` the motion data and motion.gif (when the scene holds its
    YAML data, as a scene read from a file or a mapping does). Returns (summary, file names written)."""
    summary = study_summary(study)
    names: list[str] = []

    def fill(tmp: Path) -> None:
        files = all_figures(study, tmp)
        files.append(write_timeseries_csv(study, tmp / "timeseries.csv"))
        (tmp / "report.md").write_text(report_markdown(summary))
        (tmp / MARKER).write_text(json.dumps(summary, indent=2) + "\n")
        files += [tmp / "report.md", tmp / MARKER]
        if animate and save_motion(study, tmp / MOTION) is not None:
            files += [tmp / MOTION, render(tmp, tmp / "motion.gif", progress=progress)]
        names.extend(p.name for p in files)

    atomic_directory(out, fill)
    return summary, names

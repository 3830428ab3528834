"""Atomic result directories: everything is written into a temporary sibling directory,
which replaces the target only when complete. An interrupted or failed run leaves an
earlier result as it was.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

from ..errors import SceneError
from ..study import Study
from .plots import all_figures
from .summary import study_summary
from .tables import report_markdown, write_timeseries_csv

__all__ = ["atomic_directory", "write_results", "check_target", "MARKER"]

MARKER = "summary.json"  # a directory holding it is an rrr4 result and may be replaced


def check_target(out: Path) -> None:
    if out.exists() and not out.is_dir():
        raise SceneError(f"out: '{out}' is a file (a directory is required)")
    if out.is_dir() and any(out.iterdir()) and not (out / MARKER).is_file():
        raise SceneError(f"out: '{out}' is not empty and holds no {MARKER} (give a new directory or an "
                         "earlier rrr4 result directory, which is then replaced)")


def atomic_directory(out, fill) -> Path:
    """Call fill(tmp_dir) to write files, then put tmp_dir in place of `out`.

    `out` must be absent, empty, or an earlier result (holds summary.json). If fill raises
    (or is interrupted), the temporary directory is removed and `out` is untouched.
    """
    out = Path(out)
    check_target(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.tmp-", dir=out.parent))
    try:
        fill(tmp)
        if out.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
            os.replace(out, old / out.name)
            try:
                os.replace(tmp, out)
            except BaseException:
                os.replace(old / out.name, out)
                raise
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out


def write_results(study: Study, out) -> tuple[dict, list[str]]:
    """Write figures, timeseries.csv, summary.json and report.md of `study` into `out`
    atomically. Returns (summary, file names written)."""
    summary = study_summary(study)
    names: list[str] = []

    def fill(tmp: Path) -> None:
        files = all_figures(study, tmp)
        files.append(write_timeseries_csv(study, tmp / "timeseries.csv"))
        (tmp / "report.md").write_text(report_markdown(summary))
        (tmp / MARKER).write_text(json.dumps(summary, indent=2) + "\n")
        files += [tmp / "report.md", tmp / MARKER]
        names.extend(p.name for p in files)

    atomic_directory(out, fill)
    return summary, names

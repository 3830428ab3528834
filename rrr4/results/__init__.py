"""Results of the studies: what a study produces (:mod:`.study`), metrics (:mod:`.metrics`),
tables, summaries, figures, the animation and atomic file output.

The names that draw (those of :mod:`.output`) are loaded on first use, so that importing
rrr4 loads no matplotlib and leaves its backend alone.
"""

from .metrics import arm_metrics, loss_times
from .study import ARMS, DRIVEN_ARMS, PRELOAD_ARMS, Study, StudyArm
from .summary import study_summary, target_checks
from .tables import report_markdown, write_timeseries_csv

__all__ = ["arm_metrics", "loss_times", "atomic_directory", "check_target", "write_results",
           "study_summary", "target_checks", "report_markdown", "write_timeseries_csv", "Study", "StudyArm", "ARMS",
           "PRELOAD_ARMS", "DRIVEN_ARMS"]

_OUTPUT = ("atomic_directory", "check_target", "write_results")


def __getattr__(name: str):
    if name in _OUTPUT:
        from . import output
        return getattr(output, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

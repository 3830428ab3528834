"""Results of a study: metrics, figures, tables and atomic file output."""

from .metrics import arm_metrics, loss_times
from .output import atomic_directory, check_target, write_results
from .summary import study_summary, target_checks
from .tables import report_markdown, write_timeseries_csv

__all__ = ["arm_metrics", "loss_times", "atomic_directory", "check_target", "write_results",
           "study_summary", "target_checks", "report_markdown", "write_timeseries_csv"]

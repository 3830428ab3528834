"""All plotting (matplotlib, Agg), one module per idea; each figure is written by
:func:`save_figure` (atomically) and its path returned.

- :mod:`.base`: the arms' colours and labels (:data:`STYLE`) and :func:`save_figure`;
- :mod:`.study`: the figures of a study (``rrr4 run``), :func:`all_figures`;
- :mod:`.sweep`: the figures of a sweep's results.csv (``rrr4 sweep``);
- :mod:`.map`: the workspace maps (``rrr4 map``);
- :mod:`.robustness`: the robustness cases (``rrr4 robustness``);
- :mod:`.wear`: the wear profiles and their history over the cycles (``rrr4 wear``);
- :mod:`.identification`: the fit, residuals and correlation of an identification (``rrr4 identify``);
- :mod:`.work_precision`: the work-precision diagram (``rrr4 bench accuracy``).
"""

from .base import STYLE, save_figure  # first: selects the Agg backend
from .map import plot_map
from .robustness import plot_robustness
from .study import all_figures
from .sweep import sweep_figures
from .work_precision import plot_work_precision

__all__ = ["STYLE", "save_figure", "all_figures", "sweep_figures", "plot_map", "plot_robustness",
           "plot_work_precision"]

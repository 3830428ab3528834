"""The applications, on a Problem (DESIGN section 2: the studies layer, above results/).

- :mod:`.study`: the study behind ``rrr4 run`` (the preload arms; a driven scene's
  clearance against its ideal twin);
- :mod:`.robustness`: ``rrr4 robustness``, the compensated controller on mechanisms that
  differ from its model;
- :mod:`.sweeps`: ``rrr4 sweep``, grid and Monte Carlo specs run on Dask;
- :mod:`.maps`: ``rrr4 map``, workspace maps;
- :mod:`.bench`: ``rrr4 bench accuracy``, work-precision of the integrators.

Each computes and writes its tables; the result types, metrics and every figure they use are
in :mod:`rrr4.results` (the layer below).
"""

from .bench import work_precision, write_work_precision
from .maps import workspace_map, write_map
from .robustness import robustness, write_robustness
from .study import run_study
from .sweeps import sweep

__all__ = ["run_study", "robustness", "write_robustness", "sweep", "workspace_map", "write_map", "work_precision",
           "write_work_precision"]

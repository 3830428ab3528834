"""Preload problems: pick the null-space torques so that every passive joint stays loaded.

Three formulations (DESIGN section 1.4): ``exact`` (pointwise closed form), ``qp``
(pointwise CasADi conic) and ``nlp`` (whole-horizon Opti/ipopt). Front door:
:func:`solve_preload`.
"""

from .exact import exact_preload_function
from .qp import qp_preload_function
from .solution import Infeasibility, PreloadSolution
from .solve import PreloadInfeasibleError, PreloadWarning, solve_preload

__all__ = ["exact_preload_function", "qp_preload_function", "solve_preload", "PreloadSolution", "Infeasibility",
           "PreloadWarning", "PreloadInfeasibleError"]

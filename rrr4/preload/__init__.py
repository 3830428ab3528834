"""Preload problems: pick the null-space torques so that every passive joint stays loaded.

Three formulations (DESIGN section 1.4): ``exact`` (pointwise closed form), ``qp``
(pointwise CasADi conic) and ``nlp`` (whole-horizon Opti/ipopt). Front door:
:func:`solve_preload`. The controller's pointwise law (:mod:`.laws`) and the sign policy
that picks its branch or fixed axial-force sign (:mod:`.signs`) live here too.
"""

from .exact import exact_preload_function
from .laws import law_settings, parametric_preload_law, preload_law, why_not_pointwise
from .qp import qp_preload_function
from .signs import choose_signs, preload_sign
from .solution import EffortExcess, Infeasibility, PreloadSolution
from .solve import PreloadInfeasibleError, PreloadWarning, solve_preload

__all__ = ["exact_preload_function", "qp_preload_function", "solve_preload", "PreloadSolution", "Infeasibility",
           "EffortExcess", "PreloadWarning", "PreloadInfeasibleError", "preload_law", "parametric_preload_law",
           "law_settings", "why_not_pointwise", "choose_signs", "preload_sign"]

"""Preload problems: pick the null-space torques so that every passive joint stays loaded.

Three formulations (DESIGN section 1.4): ``exact`` (pointwise closed form), ``qp``
(pointwise CasADi conic) and ``nlp`` (whole-horizon Opti/ipopt). Front door:
:func:`rrr4.preload.solve.solve_preload`.
"""

from .exact import exact_preload_function

__all__ = ["exact_preload_function"]

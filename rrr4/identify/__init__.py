"""Parameter identification from measurements (DESIGN section 11): clearances, friction,
contact stiffness and kinematic parameters of a scene from measured task poses, actuator
angles and efforts, with uncertainty and an identifiability verdict.

- :mod:`.measurements`: the measured columns (the names of a study's timeseries.csv);
- :mod:`.parameters`: what is identified, by dotted scene key;
- :mod:`.seated`: method 'seated', the quasi-static model of seated journals;
- :mod:`.dynamic`: method 'dynamic', shooting with the forward sensitivities of the compiled
  stepping (refuses a run too chaotic to shoot);
- :mod:`.multiple_shooting`: method 'dynamic' over windows (``windows=K``): the windows'
  start states as nuisance unknowns, coupled by continuity, a chaos check per window;
- :mod:`.least_squares`: Levenberg-Marquardt, covariance, identifiability;
- :mod:`.identify`: the front door :func:`identify` and its result :class:`Identification`.
"""

from .identify import METHODS, Identification, identify, verdict_text
from .least_squares import COLLINEARITY_LIMIT
from .measurements import (
                           Measurements,
                           measurement_columns,
                           measurements_from_simulation,
                           read_measurements,
)
from .parameters import DEFAULT_PARAMETERS, PATTERNS, Parameter, resolve_parameters
from .seated import seated_model

__all__ = ["identify", "Identification", "METHODS", "Measurements", "read_measurements",
           "measurements_from_simulation", "measurement_columns", "Parameter", "resolve_parameters",
           "DEFAULT_PARAMETERS", "PATTERNS", "seated_model", "COLLINEARITY_LIMIT", "verdict_text"]

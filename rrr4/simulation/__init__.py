"""Contact-dynamics simulation: the plant and the controller coupled into one ODE system
(:mod:`.system`), its initial state (:mod:`.initial`), the run (:func:`simulate`,
:mod:`.run`) and its result (:class:`Simulation`, :mod:`.result`)."""

from .result import Simulation
from .run import OVERRIDES, default_jit, frame_times, run_end, simulate
from .system import REFERENCES, problem_system
from .verdict import AUDIT_TOLERANCE, Verdict, energy_verdict, halving_check, remedy

__all__ = ["Simulation", "simulate", "problem_system", "OVERRIDES", "REFERENCES", "default_jit", "frame_times",
           "Verdict", "energy_verdict", "remedy", "halving_check", "AUDIT_TOLERANCE", "run_end"]

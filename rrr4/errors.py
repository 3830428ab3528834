"""Errors a user can act on. The CLI prints their message and exits non-zero."""


class Rrr4Error(Exception):
    """Base of rrr4's user-facing errors."""


class SceneError(Rrr4Error, ValueError):
    """A scene or argument is invalid. The message names key path, value and what is allowed."""


class SimulationError(Rrr4Error, RuntimeError):
    """A simulation cannot go on: the state became non-finite (a blow-up beyond the method's
    stability limit, or its solver gave up). The message names the method and the step."""


class KinematicsError(Rrr4Error, RuntimeError):
    """A kinematic problem has no solution (unreachable pose, FK without convergence)."""


class InfeasibleError(Rrr4Error, RuntimeError):
    """An optimal-control problem has no solution: the message names where along the path
    (or at which node) and which constraint (an actuator's limit, a joint's contact condition)."""


class MeasurementError(Rrr4Error, ValueError):
    """A measurement file or array cannot be used: the message names the file, the column
    (and row), the value and what is allowed."""


class SolverError(Rrr4Error, RuntimeError):
    """A numerical solver stopped without an answer where one exists (an optimal-control
    problem known to be feasible): the message names the solver's status and what to change."""

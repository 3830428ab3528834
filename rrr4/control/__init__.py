"""The one controller (DESIGN sections 1.3(b) and 7): the controller step
(:mod:`.step`), its feedback law (:mod:`.feedback`), the clearance compensation
(:mod:`.compensation`), the references tabulated along the path (:mod:`.references`) and
the step of a scene without a closed-form one, on those references (:mod:`.table`).
Every function takes the built :class:`~rrr4.problem.Problem`."""

from .compensation import compensated_ik, seat_gaps
from .feedback import feedback_function, feedback_settings, parametric_feedback
from .references import References, graph_references, path_rows, prescribed_references, reference_function, tabulated
from .step import controller_function, controller_settings, parametric_controller, pointwise_controller
from .table import controller_step, interpolants, reference_grid, step_inputs, table_controller

__all__ = ["controller_function", "parametric_controller", "controller_settings", "pointwise_controller",
           "feedback_function", "parametric_feedback", "feedback_settings", "seat_gaps", "compensated_ik",
           "References", "graph_references", "prescribed_references", "reference_function", "tabulated",
           "path_rows", "controller_step", "table_controller", "reference_grid", "interpolants",
           "step_inputs", "CONTROLLERS"]

CONTROLLERS = ("python", "generated")  # simulate(controller=...): CasADi's VM/JIT, or the codegen C

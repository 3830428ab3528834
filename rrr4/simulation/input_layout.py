"""The layout of a simulation's per-frame inputs, in one place.

A run steps frames (:class:`rrr4.integrators.System`); frame k gets one row of inputs
u_frame, constant over the frame, that starts with its times [t_a, t_b]. What follows depends
on how the efforts enter the right-hand side (:class:`rrr4.simulation.system.Loop`):

- 'exact': nothing (the controller step runs inside the right-hand side at the path's time);
- 'sampled': the tabulated references at both frame ends, per actuator: th, thd, thdd, ff,
  ffd, each as [at t_a (n), at t_b (n)];
- 'held' with a tabulated controller: its references at t_a: th, thd, ff (n each);
- 'held' with a pointwise controller step: the step's inputs before the measured theta and
  theta_d at t_a (the pose, its rate and acceleration, 3 each, or the time), see
  :func:`rrr4.control.step_inputs`.

With 'held' the controller runs once per frame and the right-hand side's input is
[t_a, t_b, efforts (n)] (:attr:`InputLayout.effort`). :class:`InputLayout` names each block as
a slice; the Loop carries it (built once with it, :func:`rrr4.simulation.system.loop_of`), and
every writer of these rows (the run, identification's shooting) and every reader (the
System's right-hand side and held controller) goes through it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["InputLayout", "TIMES", "SAMPLED", "HELD"]

TIMES = slice(0, 2)  # [t_a, t_b], first in every row
SAMPLED = ("th", "thd", "thdd", "ff", "ffd")  # a sampled loop's references, each at t_a then at t_b
HELD = ("th", "thd", "ff")  # a held tabulated controller's references at t_a


@dataclass(frozen=True)
class InputLayout:
    """kind: 'exact', 'sampled' or 'held'; n: the actuators; step: a held pointwise
    controller step's input sizes before theta (empty: a held loop takes tabulated references)."""
    kind: str
    n: int
    step: tuple[int, ...] = ()

    @property
    def width(self) -> int:
        """The entries of one frame's row."""
        return 2 + {"exact": 0, "sampled": 10 * self.n, "held": sum(self.step) if self.step else 3 * self.n}[self.kind]

    @property
    def ode_width(self) -> int:
        """The entries of the right-hand side's input: the row, or with 'held' [t_a, t_b, efforts]."""
        return 2 + self.n if self.kind == "held" else self.width

    @property
    def effort(self) -> slice:
        """The held efforts in the right-hand side's input ('held')."""
        return slice(2, 2 + self.n)

    def reference(self, name: str, end: int = 0) -> slice:
        """A tabulated reference block (:data:`SAMPLED` at end 0 (t_a) or 1 (t_b); :data:`HELD` at t_a)."""
        names = SAMPLED if self.kind == "sampled" else HELD
        k = 2 * names.index(name) + end if self.kind == "sampled" else names.index(name)
        return slice(2 + self.n * k, 2 + self.n * (k + 1))

    def step_inputs(self) -> list[slice]:
        """The blocks of a held pointwise controller step's inputs, in order."""
        ends = np.cumsum([2, *self.step]).tolist()
        return [slice(a, b) for a, b in zip(ends[:-1], ends[1:], strict=True)]

    def rows(self, t: np.ndarray, references: dict | None = None, step: list | None = None) -> np.ndarray:
        """(len(t) - 1, width) rows of the frames between the times t (frame ends): the times,
        then the tabulated `references` {name: (len(t), n)} at the frame ends, or the held
        step's inputs `step` (its blocks, each (size, len(t) - 1), at the frames' starts)."""
        t = np.asarray(t, float)
        cols = [t[:-1], t[1:]]
        if self.kind == "sampled" and references is not None:
            cols += [v for name in SAMPLED for v in (references[name][:-1], references[name][1:])]
        elif self.kind == "held" and not self.step:
            cols += [references[name][:-1] for name in HELD]
        elif self.kind == "held":
            cols += [v.T for v in step]
        return np.column_stack(cols)

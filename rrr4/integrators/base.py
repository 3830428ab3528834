"""One small interface for fixed-step integrators whose stepping runs inside compiled
CasADi, never as a Python loop calling CasADi per step.

A :class:`System` is an ODE with a discrete state: y' = f(t, y, z, u) between steps and
z <- g(t, y, z) after each step (contact onset/loss), which also carries the running maxima
of the system's `peaks` over every step (so that a peak between two outputs is not missed).
A method only implements
:meth:`FixedStepIntegrator.advance` (one step of y). The base class

- builds ``step``: x = [t, y, z], u -> x_next (one step plus the discrete update),
- with ``refine = k > 1``, re-takes a step as k sub-steps of h/k (discrete update after each)
  when the discrete state changes over it, i.e. a contact onset or loss happened inside the
  step; the switch is a ``Function.if_else``, so the compiled code pays for the k sub-steps
  only at those steps. The onset approach velocity is then captured within h/k of the
  crossing instead of h (the onset rule is first order in the capture delay),
- folds ``steps_per_frame`` steps into ``frame``, which returns the state at the frame end
  (a sampled controller, ``System.control``, runs once at the frame start and holds its
  output over the frame's steps), folds the frames of one output interval into one unit
  (optionally JIT-compiled) and rolls the units with ``mapaccum``, keeping only each
  output's public state,
- runs the output intervals in about :data:`CALLS` calls of at most :data:`MAX_CHUNK` intervals
  (so that long runs show a progress bar and what a call builds stays small; a call per 50
  frames cost a third of the reference scene's stepping), each with its
  frame inputs and kept states passed through CasADi's buffer interface (:func:`evaluate`),
  not converted to and from DM, into one array of the outputs or, given a ``sink``, to it a
  call at a time (what the run holds then does not grow with its outputs),
- keeps the built (and compiled) frame Function on the system (per method settings, step
  and steps per frame), so a second run of the same scene builds nothing, and dropping the
  system frees them.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..errors import Rrr4Error
from ..files import stop_requested
from ..functions import evaluate, one_direction_derivatives

BACKGROUND = "background"  # jit: compile the stepping in a process of its own, step in the VM until it is done
CALLS = 20  # calls from Python that a run's stepping is split into (progress-bar updates)
# output intervals per call at most: CasADi's mapaccum over k intervals takes memory that grows
# with k while it is built (measured: 14 MB at k = 100, 160 MB at 1000) and keeps part of it as
# long as the system lives, so a long run would pay for its length; 64 costs no measurable time
MAX_CHUNK = 64


class FrameInputs:
    """A run's frame inputs, (n_frames, nu), made a block of frames at a time: rows(a, b) gives
    the rows of frames a..b-1. A long run then holds the inputs of the frames it is stepping,
    not of all its frames (at 10 kHz control, 60 s are 6e5 rows), so what it holds grows with
    its outputs. Indexed like the array it stands for, with a slice or a frame number (a
    number makes and keeps the block of :attr:`BLOCK` frames around it). `seconds`: the wall
    time spent making them, so that a run's stepping can be timed without it."""

    BLOCK = 4096

    def __init__(self, n_frames: int, nu: int, rows):
        self.shape = (n_frames, nu)
        self._rows = rows
        self._block: tuple[int, np.ndarray | None] = (-1, None)
        self.seconds = 0.0

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, key):
        n = self.shape[0]
        if isinstance(key, slice):
            a, b, step = key.indices(n)
            if step != 1:
                raise IndexError("FrameInputs: only contiguous slices")
            t0 = time.perf_counter()
            block = np.asarray(self._rows(a, b), float).reshape(max(b - a, 0), self.shape[1])
            self.seconds += time.perf_counter() - t0
            return block
        k = int(key) + (n if int(key) < 0 else 0)
        i = k // self.BLOCK
        if self._block[0] != i:
            self._block = (i, self[i * self.BLOCK:min(n, (i + 1) * self.BLOCK)])
        return self._block[1][k - i * self.BLOCK]


def frame_inputs(u_frames) -> FrameInputs | np.ndarray:
    """`u_frames` as integrators index it: a FrameInputs as it is, else a 2-D float array."""
    return u_frames if isinstance(u_frames, FrameInputs) else np.atleast_2d(np.asarray(u_frames, float))


@dataclass(frozen=True)
class Run:
    """What an integrator's run returns: states (n_outputs, System.kept) at the end of each
    output frame (None when a sink took them), and its statistics (e.g. Newton iterations,
    accepted and rejected steps)."""
    states: np.ndarray | None
    stats: dict


@dataclass(frozen=True)
class System:
    """ode: t, y, z, u -> y_dot; discrete: t, y, z -> z_next (both CasADi Functions).
    u is constant over a frame (e.g. reference samples at the frame's two ends) and starts
    with the frame's [t_a, t_b].

    control (optional): y, z, u_frame -> u, a sampled controller with zero-order hold. It
    runs once at the start of every frame on the state there (z may carry its settings), and
    its output (which keeps the frame's [t_a, t_b] first) is the ODE's u over the whole frame;
    the frame inputs u_frame then carry the controller's references.

    peaks (optional): t, y, z, u -> values (m,) whose running maxima over every step are the
    last m entries of z (a minimum is the maximum of its negative); `discrete` leaves them as
    they are and :meth:`update` raises them."""
    ode: ca.Function
    discrete: ca.Function
    control: ca.Function | None = None
    c_sources: tuple = ()  # C files that must be compiled with the frames (e.g. an external controller's)
    # the leading entries of z whose change over a step is an event (a contact opening or
    # closing); None: all of z. The rest (e.g. constant parameters) never changes.
    n_events: int | None = None
    peaks: ca.Function | None = None
    layout: object = None  # the named parts of y and z (simulation.state_layout.StateLayout); opaque here
    # (method, settings, h, steps per frame, frames per output) -> the built (and compiled)
    # unit of work; (that key, units per call, entries kept) -> the call that rolls it; the
    # implicit methods' Newton solvers; and "update" (see :meth:`update`): the system owns
    # them, so they live exactly as long as it does
    frames: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def ny(self) -> int:
        return self.ode.size1_in(1)

    @property
    def nz(self) -> int:
        return self.ode.size1_in(2)

    @property
    def events(self) -> int:
        """How many leading entries of z can change at an event (see n_events)."""
        return self.nz if self.n_events is None else self.n_events

    @property
    def n_peaks(self) -> int:
        """How many running maxima end z (see peaks)."""
        return 0 if self.peaks is None else self.peaks.size1_out(0)

    @property
    def kept(self) -> int:
        """How many entries of a state a run returns at each output (:attr:`kept_entries`)."""
        return 1 + self.ny + self.events + self.n_peaks

    @property
    def kept_entries(self) -> tuple[slice, slice]:
        """Where they are in a state [t, y, z, ...]: t, y and the leading `events` entries of
        z, then the running maxima at the end of z. The rest of z never changes: it is the
        initial state's."""
        end = 1 + self.ny + self.nz
        return slice(0, 1 + self.ny + self.events), slice(end - self.n_peaks, end)

    def update(self, t, y, z, u):
        """z after a step that ends at (t, y) with u held over it (numeric or symbolic): the
        discrete update, then the running maxima raised to the peaks at the new state."""
        if self.peaks is None:
            return self.discrete(t, y, z)
        if "update" not in self.frames:  # one graph: the peaks share the contact geometry with the update
            ts, ys, zs, us = (ca.SX.sym(name, self.ode.sparsity_in(i)) for i, name in enumerate("tyzu"))
            z1 = self.discrete(ts, ys, zs)
            a = self.nz - self.n_peaks
            z1 = ca.vertcat(z1[:a], ca.fmax(z1[a:], self.peaks(ts, ys, z1, us)))
            self.frames["update"] = ca.Function("update", [ts, ys, zs, us], ca.cse([z1]), ["t", "y", "z", "u"],
                                                ["z_next"])
        return self.frames["update"](t, y, z, u)

    def started(self, x0, u_frame) -> np.ndarray:
        """The initial state [t, y, z] of x0 = [t, y, z without its running maxima]: the maxima
        start at the peaks there (u_frame: the first frame's input), so that a run's include
        its start."""
        x0 = np.r_[np.asarray(x0, float), np.zeros(self.n_peaks)]
        if self.peaks is not None:
            y, z = x0[1:1 + self.ny], x0[1 + self.ny:]
            x0[self.kept_entries[1]] = np.array(self.peaks(x0[0], y, z, self.held(y, z, u_frame))).ravel()
        return x0

    @property
    def nu(self) -> int:
        return self.ode.size1_in(3)

    @property
    def nu_frame(self) -> int:
        """Size of a frame's input: the controller's references, or the ODE's u."""
        return self.nu if self.control is None else self.control.size1_in(2)

    def held(self, y, z, u_frame):
        """The ODE's u over a frame that starts at state y, z (numeric or symbolic)."""
        return u_frame if self.control is None else self.control(y, z, u_frame)


class Integrator(ABC):
    """The one interface of every method: a `name`, its `order`, capabilities (adaptive:
    error control instead of a step; compiles: jit=True steps in generated C; ladder: the
    steps [s] or tolerances `rrr4 bench accuracy` tries by default), :meth:`from_settings`
    (the method configured by a scene's IntegratorSettings) and :meth:`run`."""
    name = ""
    order = 0
    adaptive = False
    compiles = True
    ladder: tuple[float, ...] = ()
    jit = False

    @classmethod
    @abstractmethod
    def from_settings(cls, settings, jit: bool = False) -> Integrator:
        """The method configured by a scene's IntegratorSettings."""

    def settings_key(self) -> tuple:
        """The method and the values it was configured with (its public attributes, sorted by
        name): what a System's compiled frames are keyed on, so two integrators configured alike
        share them. Every public attribute is a plain value (bool, int, float, str, None, or a
        tuple of them); anything else is a TypeError, never a key that only looks alike."""
        def plain(name, v):
            if isinstance(v, tuple):
                return tuple(plain(name, x) for x in v)
            if v is None or isinstance(v, (bool, int, float, str)):
                return v
            raise TypeError(f"{type(self).__name__}.{name}: {type(v).__name__} is not a plain setting value")
        return type(self).__name__, tuple(sorted((k, plain(k, v)) for k, v in vars(self).items()
                                                 if not k.startswith("_")))

    @abstractmethod
    def run(self, system: System, x0, u_frames, h: float, steps_per_frame: int, chunk: int | None = None,
            progress: bool = False, every: int = 1, sink=None) -> Run:
        """States at the end of every `every`-th frame, (n_frames / every, system.kept), and
        the run's statistics; frame k spans [u[k, 0], u[k, 1]], h [s] is the step (or a
        first-step hint of an adaptive method). sink(k, states): given, it receives the
        states of outputs k, k + 1, ... ((m, system.kept), valid during the call) as the run
        makes them, and Run.states is None."""


class FixedStepIntegrator(Integrator):
    """Base of fixed-step methods. Subclasses set `name`, `order` and implement `advance`.

    Capabilities: adaptive = False (a step, no error control); compiles = True (jit=True
    steps in generated C); ladder: the steps [s] `rrr4 bench accuracy` tries by default."""
    adaptive = False
    compiles = True
    ladder: tuple[float, ...] = (1e-3, 5e-4, 2.5e-4, 2e-4, 1e-4, 5e-5, 2e-5)

    def __init__(self, jit: bool = False, refine: int = 1):
        if int(refine) != refine or refine < 1:
            raise Rrr4Error(f"integrator.refine: {refine!r} is not allowed (must be an integer >= 1)")
        self.jit, self.refine = jit, int(refine)

    @classmethod
    def from_settings(cls, settings, jit: bool = False):
        """The method configured by a scene's IntegratorSettings (methods with parameters override this)."""
        return cls(jit=jit, refine=settings.refine)

    @abstractmethod
    def advance(self, ode: ca.Function, t, y, z, u, h: float):
        """y at t + h from y at t (symbolic); z and u are held over the step."""

    def step_function(self, system: System, h: float) -> ca.Function:
        """SX Function 'step': x (1 + ny + nz,), u (nu,) -> x_next."""
        ny, nz = system.ny, system.nz
        x, u = ca.SX.sym("x", 1 + ny + nz), ca.SX.sym("u", system.nu)
        t, y, z = x[0], x[1:1 + ny], x[1 + ny:]
        y1 = self.advance(system.ode, t, y, z, u, h)
        z1 = system.update(t + h, y1, z, u)
        return ca.Function("step", [x, u], ca.cse([ca.vertcat(t + h, y1, z1)]), ["x", "u"], ["x_next"])

    def refined_step_function(self, system: System, h: float, inline: bool = False) -> ca.Function:
        """'step' (x, u -> x_next) that re-takes the step as `refine` sub-steps of h/refine
        when the event part of the discrete state (x[1 + ny : 1 + ny + events]) changes over it
        (inline: the step's graph inlined in it, an MX step's, see :meth:`derivative_frame_function`)."""
        step = self.step_function(system, h)
        if self.refine == 1 or system.events == 0:
            return step
        k, ny, ne = self.refine, system.ny, system.events
        fine = self.step_function(system, h / k).mapaccum("sub_steps", k)
        x, u, x1 = ca.MX.sym("x", step.size1_in(0)), ca.MX.sym("u", system.nu), ca.MX.sym("x1", step.size1_in(0))
        keep = ca.Function("coarse", [x, u, x1], [x1])
        redo = ca.Function("refined", [x, u, x1], [fine(x, ca.repmat(u, 1, k))[:, -1]])
        choose = ca.Function.if_else("refine_if_event", redo, keep)
        x1 = _called(step, inline)(x, u)
        event = ca.norm_inf(x1[1 + ny:1 + ny + ne] - x[1 + ny:1 + ny + ne]) > 0
        return ca.Function("step", [x, u], [choose(event, x, u, x1)], ["x", "u"], ["x_next"])

    def frame_function(self, system: System, h: float, steps_per_frame: int) -> ca.Function:
        """MX Function 'frame': x, u -> x after `steps_per_frame` steps (mapaccum)."""
        return self._frame(system, self.refined_step_function(system, h), steps_per_frame, inline=False)

    def derivative_frame_function(self, system: System, h: float, steps_per_frame: int) -> ca.Function:
        """'frame' as :meth:`frame_function` (the same x_next), built to be differentiated in
        many directions (``Function.forward(n)``, rrr4.identify's sensitivities): `system` from
        ``system_of(..., derivatives=True)``, the step's Functions built under
        :func:`rrr4.functions.one_direction_derivatives`, and an MX step (an implicit method's)
        inlined in the frame. Its forward derivative in n directions then evaluates each step
        once and calls the one-direction derivatives of the step's leaves (right-hand side,
        contact update, an implicit stage's last update) n times: code that hardly grows with n,
        and no step recomputed per direction. A step re-taken in sub-steps (``refine``) is
        differentiated one direction at a time (sub-steps recomputed per direction: rare)."""
        with one_direction_derivatives():
            step = self.refined_step_function(system, h, inline=True)
        return self._frame(system, step, steps_per_frame, inline=True)

    def _frame(self, system: System, step: ca.Function, steps_per_frame: int, inline: bool) -> ca.Function:
        call = _called(step, inline)
        x, u, x_k = ca.MX.sym("x", step.size1_in(0)), ca.MX.sym("u", system.nu_frame), ca.MX.sym("x", step.size1_in(0))
        ny, nz = system.ny, system.nz
        held = system.held(x[1:1 + ny], x[1 + ny:1 + ny + nz], u)
        if steps_per_frame == 1:  # one step per frame (a control period): no fold, one copy less
            return ca.Function("frame", [x, u], [call(x, held)], ["x", "u"], ["x_next"])
        u_held = ca.MX.sym("u", system.nu)
        # fold: only the frame's last state is stored (moving states costs as much as computing them)
        roll = ca.Function("held_step", [x_k, u_held], [call(x_k, u_held)], ["x", "u"], ["x_next"]).fold(
            steps_per_frame)
        x1 = roll(x, ca.repmat(held, 1, steps_per_frame))
        return ca.Function("frame", [x, u], [x1], ["x", "u"], ["x_next"])

    def run(self, system: System, x0, u_frames, h: float, steps_per_frame: int, chunk: int | None = None,
            progress: bool = False, every: int = 1, sink=None) -> Run:
        """States at the end of every `every`-th frame, (n_frames / every, system.kept), and
        statistics; u_frames (n_frames, nu), an array or :class:`FrameInputs`; n_frames a
        multiple of `every`; sink: see :meth:`Integrator.run`."""
        states, _, stepping = self.roll(system, x0, u_frames, h, steps_per_frame, chunk, progress, every=every,
                                        sink=sink)
        return Run(states, {"stepping": stepping})

    def roll(self, system: System, x0, u_frames, h: float, steps_per_frame: int, chunk: int | None = None,
             progress: bool = False, every: int = 1, sink=None) -> tuple[np.ndarray | None, np.ndarray]:
        """(the kept entries (:attr:`System.kept_entries`) of the state at the end of every
        `every`-th frame, or None
        when `sink` took them a call at a time, see :meth:`Integrator.run`; the last full
        state): what a run keeps grows with the outputs (with a sink, not even that), never
        with the frames, the steps or a method's own state (Newton factors). Converting
        results out of CasADi costs about as much per number as a right-hand side per
        instruction, so the rest stays inside. chunk: frames per call from Python (None: the
        run in about CALLS calls)."""
        u_frames = frame_inputs(u_frames)
        n_frames = u_frames.shape[0]
        if n_frames % every:
            raise ValueError(f"{n_frames} frames are not a multiple of every = {every}")
        key = (*self.settings_key(), float(h), int(steps_per_frame), int(every))
        if key not in system.frames:
            # the unit of work is one output interval: `every` frames folded in one Function,
            # so the virtual machine calls it once per output, not once per frame
            unit = self.frame_function(system, h, steps_per_frame)
            if every > 1:
                xu, uu = ca.MX.sym("x", unit.size1_in(0)), ca.MX.sym("u", unit.size1_in(1), every)
                unit = ca.Function("interval", [xu, uu], [unit.fold(every)(xu, uu)], ["x", "u"], ["x_next"])
            if self.jit == BACKGROUND:  # the C compiled by a process of its own if that pays; the VM steps meanwhile
                from .compiled import compiled_later
                ready, lib, compiling, decided = compiled_later(unit, system.c_sources, n_frames * steps_per_frame)
                if compiling:
                    system.frames[key, "pending"] = lib
                system.frames[key, "decided"] = decided, ready is not None or compiling, lib
                unit = ready or unit
            elif self.jit:  # generated C of the whole loop, cached on disk (see .compiled)
                from .compiled import compiled
                unit = compiled(unit, system.c_sources)
            system.frames[key] = unit
        unit = system.frames[key]
        decided, compiles, lib = system.frames.get((key, "decided"), (None, None, None))
        stepping = {"compiled": bool(self.jit) and compiles is not False and (key, "pending") not in system.frames,
                    "compiled_from_frame": None}
        if decided is not None:
            stepping["decision"] = decided
        timed = {True: [0.0, 0], False: [0.0, 0]}  # compiled or not: [seconds stepping, steps]
        n_units = n_frames // every
        chunk = max(1, chunk // every) if chunk else min(max(1, -(-n_units // CALLS)), MAX_CHUNK)  # intervals per call
        x = np.asarray(x0, float)
        keep = system.kept
        out = np.empty((n_units, keep)) if sink is None else None
        bar = None
        if progress:
            from tqdm import tqdm
            bar = tqdm(total=n_frames, desc=f"simulate ({self.name})", unit="frame")
        try:
            for k0 in range(0, n_units, chunk):
                if stop_requested():  # an interrupt lost inside a solver (see rrr4.files.request_stop)
                    raise KeyboardInterrupt
                k = min(chunk, n_units - k0)
                if (key, "pending") in system.frames and system.frames[key, "pending"].exists():
                    unit = self._switch_to_compiled(system, key)  # the same states, bit for bit, from here on
                    stepping.update(compiled=True, compiled_from_frame=k0 * every)
                if (key, k, keep) not in system.frames:  # the kept rows at each output and the last full state
                    xm, um = ca.MX.sym("x", x.size), ca.MX.sym("u", u_frames.shape[1], k * every)
                    xs = unit.mapaccum("outputs", k)(xm, um)
                    head, peaks = system.kept_entries
                    system.frames[key, k, keep] = ca.Function("chunk", [xm, um], [
                        ca.vertcat(xs[head, :], xs[peaks, :]), xs[:, -1]])
                # (k * every, nu) rows in C order are the (nu, k * every) input in CasADi's column
                # order, and the (keep, k) output is out's rows k0..k0+k: no conversion to DM
                last = np.empty(x.size)
                kept = out[k0:k0 + k] if sink is None else np.empty((k, keep))
                rows = np.ascontiguousarray(u_frames[k0 * every:(k0 + k) * every], float)
                t0 = time.perf_counter()
                evaluate(system.frames[key, k, keep], [x, rows], [kept, last])
                timed[stepping["compiled"]][0] += time.perf_counter() - t0
                timed[stepping["compiled"]][1] += k * every * steps_per_frame
                if sink is not None:
                    sink(k0, kept)
                x = last
                if bar is not None:
                    bar.update(k * every)
        finally:  # an error or interrupt must not leave a half-drawn bar under its message
            if bar is not None:
                bar.close()
        if decided is not None:  # what this library's steps cost here, for the policy's next estimate
            from .compiled import remember_stepping
            remember_stepping(lib, timed)
        return out, x, stepping

    @staticmethod
    def _switch_to_compiled(system: System, key) -> ca.Function:
        """The frame of `key` from its library compiled in the background (now on disk), in
        place of the virtual machine's; the chunk Functions built on the old one are dropped."""
        from .compiled import load
        lib = system.frames.pop((key, "pending"))
        unit = load(system.frames[key].name(), lib)
        system.frames[key] = unit
        for k in [k for k in system.frames if isinstance(k, tuple) and len(k) == 3 and k[0] == key]:
            del system.frames[k]
        return unit


def _called(f: ca.Function, inline: bool):
    """f's call on MX arguments (its first output), with an MX Function's graph inlined when
    `inline` (an SX Function cannot be inlined in MX: called)."""
    if inline and f.is_a("MXFunction"):
        return lambda *args: f.call(list(args), True)[0]
    return lambda *args: f(*args)

"""Error control of the implicit methods: adaptive steps inside the compiled frames.

With ``integrator.tolerance`` set, an implicit method's step h is its largest step, and a
frame is crossed by steps h / 2^k, level k = 0 .. :data:`HALVINGS`. Each attempt takes one
step at the current level with the local position-error estimate of
:meth:`~rrr4.integrators.implicit.ImplicitIntegrator.estimated_step_function` and

- accepts it when the state is finite, every Newton stage converged, the error is within
  the tolerance (at the smallest step: whatever the error, counted in
  ``steps_above_tolerance``), and, when a contact opened or closed over it, the step is at
  most h / ``refine`` (so the onset rule captures the approach velocity as finely as the
  fixed-step refinement does);
- otherwise rejects it: the state is left as it was (a rejected step never writes its
  result, finite or not) and the level goes down by as many halvings as the error asks for
  (two for a non-finite step or an unconverged stage);
- after an accepted step, goes up one level when the error allows twice the step and the
  step's end lies on the coarser grid (so every frame ends exactly on its end time);
- fails when a step at the smallest level is not finite or its Newton stages do not
  converge: the state stays at the last accepted step, and the run reports the time and the
  step (:attr:`~rrr4.integrators.base.Run.stats` ``failure``).

Levels instead of arbitrary step sizes keep the Newton factors of
:mod:`.implicit` valid while the level holds, and make the step grid exact. CasADi has no
while loop, so a frame's attempts are nested blocks, each behind a ``Function.if_else``
switch that skips it once the frame is done: a frame that needs one step pays one attempt
and two switches; the nested capacity covers every frame at the smallest step.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from .base import System

__all__ = ["HALVINGS", "ADAPTIVE", "adaptive_frame", "initial_adaptive"]

HALVINGS = 12        # the smallest step is h / 2^HALVINGS
SAFETY = 0.9         # step-size controller's safety factor
NESTING = 8          # attempts of one block in the next one up
# the entries error control appends to the implicit state
ADAPTIVE = ("position", "level", "failed", "accepted_steps", "rejected_steps", "steps_above_tolerance",
            "deepest_level")


def initial_adaptive() -> np.ndarray:
    return np.zeros(len(ADAPTIVE))


def _guarded(name: str, f: ca.Function, done) -> ca.Function:
    """x, u -> x unchanged when done(x), else f(x, u); f runs only when needed."""
    x, u = ca.MX.sym("x", f.size1_in(0)), ca.MX.sym("u", f.size1_in(1))
    switch = ca.Function.if_else(f"{name}_switch", ca.Function(f"{name}_skip", [x, u], [x]), f)
    return ca.Function(name, [x, u], [switch(done(x), x, u)], ["x", "u"], ["x_next"])


def adaptive_frame(method, system: System, h: float, steps_per_frame: int, counters: int, n_counters: int,
                   failures: int) -> ca.Function:
    """MX Function 'frame': x = [implicit state, ADAPTIVE], u_frame -> x at the frame end
    (the frame spans steps_per_frame h, from u's t_a). counters: where the implicit state's
    counters start (n_counters of them, then the renew flag); failures: the index of its
    count of unconverged stages."""
    K = HALVINGS
    units = steps_per_frame * 2 ** K  # the frame in units of the smallest step
    delta = h / 2 ** K
    ny = system.ny
    step = method.estimated_step_function(system, None)  # the step size is an input
    nx = step.size1_in(0)
    o, i_fail = counters, failures
    k_event = min(K, math.ceil(math.log2(method.refine)))
    tol = method.tolerance
    exponent = -1.0 / (method.order + 1)

    x, u = ca.MX.sym("x", nx + len(ADAPTIVE)), ca.MX.sym("u", system.nu)
    xs = x[:nx]
    m, k, failed, accepted, rejected, above, deepest = ca.vertsplit(x[nx:])
    x1, error = step(xs, u, h * 2 ** -k)
    ratio = error / tol
    sound = ca.logic_and(error < np.inf, x1[i_fail] == xs[i_fail])  # finite, and every stage converged
    ne = system.events
    event = ca.norm_inf(x1[1 + ny:1 + ny + ne] - xs[1 + ny:1 + ny + ne]) > 0 if ne else ca.MX(0)
    event_ok = ca.logic_or(ca.logic_not(event), k >= k_event)
    at_min = k >= K
    live = failed == 0  # after a failure nothing moves
    accept = live * ca.logic_and(ca.logic_and(sound, event_ok), ca.logic_or(ratio <= 1, at_min))
    fail = live * ca.logic_and(at_min, ca.logic_not(sound))
    size = 2 ** (K - k)  # the step in units of the smallest
    factor = SAFETY * ca.fmax(ratio, 1e-12) ** exponent
    m1 = m + size
    grow = ca.logic_and(ca.logic_and(factor >= 2, k > 0), ca.fmod(m1, 2 * size) == 0)
    # too large an error: the halvings it asks for; not finite or not converged: two
    halvings = ca.if_else(sound, ca.fmax(ca.ceil(ca.log(1 / factor) / math.log(2)), 1), 2)
    k_reject = ca.fmin(K, ca.fmax(k + halvings, (1 - event_ok) * k_event))
    # accepted: the step's state, its time on the frame's exact grid; rejected: the state as it
    # was. Either way the work is counted, and the Newton slots come from the attempt (after a
    # rejection they are renewed before use, so they are never read if the attempt was not finite).
    # Only the first o entries are selected: the state is mostly Newton factors, and copying costs.
    x_next = ca.vertcat(
        ca.if_else(accept, ca.vertcat(u[0] + m1 * delta, x1[1:o]), xs[:o]),
        x1[o:o + n_counters],
        ca.if_else(accept, x1[o + n_counters], 1),
        x1[o + n_counters + 1:],
        ca.if_else(accept, m1, m),
        ca.if_else(accept, k - grow, ca.if_else(ca.logic_or(fail, failed > 0), k, k_reject)),
        ca.fmax(failed, fail),
        accepted + accept,
        rejected + live * (1 - accept) * (1 - fail),
        above + accept * (ratio > 1),
        ca.fmax(deepest, k))
    attempt = ca.Function("attempt", [x, u], [x_next], ["x", "u"], ["x_next"])

    def done(xx):
        return ca.logic_or(xx[nx + 2] > 0, xx[nx] >= units)

    # nested blocks: each holds `n` of the one below behind its switch
    blocks, capacity, per, n = [], 1, 1, 2
    inner = _guarded("attempt_if_needed", attempt, done)
    while capacity < 2 * units + 4 * K:
        xb, ub = ca.MX.sym("x", x.size1()), ca.MX.sym("u", system.nu)
        block = ca.Function(f"attempts_{len(blocks)}", [xb, ub], [inner.fold(n)(xb, ca.repmat(ub, 1, n))],
                            ["x", "u"], ["x_next"])
        inner = _guarded(f"attempts_{len(blocks)}_if_needed", block, done)
        blocks.append(inner)
        per *= n
        capacity += per
        n = NESTING

    xf, uf = ca.MX.sym("x", x.size1()), ca.MX.sym("u", system.nu_frame)
    u_held = system.held(xf[1:1 + ny], xf[1 + ny:1 + ny + system.nz], uf)
    xk = ca.vertcat(xf[:nx], 0, xf[nx + 1:])  # position 0: the frame starts
    xk = _guarded("first_attempt", attempt, done)(xk, u_held)  # after a failure: nothing at all
    # the common frame (one accepted step) pays one switch for the rest: each switch copies the state
    xr, ur = ca.MX.sym("x", x.size1()), ca.MX.sym("u", system.nu)
    rest = xr
    for block in blocks:
        rest = block(rest, ur)
    xk = _guarded("more_attempts", ca.Function("more_attempts", [xr, ur], [rest], ["x", "u"], ["x_next"]),
                  done)(xk, u_held)
    # a frame not finished within the capacity is a failure too (it cannot happen while the
    # capacity covers the frame at the smallest step, but the flag must never lie)
    xk = ca.vertcat(xk[:nx + 2], ca.fmax(xk[nx + 2], xk[nx] < units), xk[nx + 3:])
    return ca.Function("frame", [xf, uf], [xk], ["x", "u"], ["x_next"])

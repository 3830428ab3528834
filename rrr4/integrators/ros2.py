"""ROS2, a linearly implicit two-stage W-method (Verwer, Spee, Blom & Hundsdorfer 1999).

One step of y' = f(t, y) with a matrix J that approximates df/dy:

    (I - g h J) k1 = f(t, y_n)
    (I - g h J) k2 = f(t + h, y_n + h k1) - 2 k1
    y_{n+1} = y_n + h (3/2 k1 + 1/2 k2),            g = 1 + 1/sqrt(2).

It is second order for *any* J (a W-method: the order conditions do not involve J), and
L-stable with the exact Jacobian (its stability function R(z) = (1 + (1 - 2g) z +
(g^2 - 2g + 1/2) z^2) / (1 - g z)^2 vanishes at infinity). There is no Newton iteration:
a step costs two right-hand sides and two solves with one matrix.

The systems of rrr4 are second order, y = [q, v, e] with q' = v, v' = a(t, q, v, z, u) and
quadratures e' = p that feed nothing back (see :mod:`.implicit`). J takes the rows
[[0, I, 0], [A_q, A_v, 0], [0, 0, 0]] (A_q = da/dq, A_v = da/dv; the quadratures' rows may
be anything, and zero costs nothing), so a solve (I - c J) k = r with c = g h is

    G k_v = r_v + c A_q r_q,   k_q = r_q + c k_v,   k_e = r_e,   G = I - c (A_v + c A_q),

the iteration matrix of the implicit methods, factorised by the same fixed-pattern sparse
QR (``casadi.qr_sparse``). The factors of G and the nonzeros of A_q are part of the state and
are reused across steps and control periods (the W-method keeps its order with them); they
are renewed

- at the first step, and when the step changes (the refined sub-steps of a contact event),
- after a step in which a contact opened or closed (the event part of the discrete state);
  such a step is also taken again with the matrix at its end: a matrix from before an impact
  lacks the contact stiffness the step meets, and the step would treat it explicitly (on the
  reference scene without preload that blows up within 0.07 s at 1e-4 s, even with a new
  Jacobian at every step's start),
- after `hold` steps with one matrix (``newton: full`` in a scene: every step, the classic
  Rosenbrock method with the exact Jacobian).

A renewal is behind a ``Function.if_else`` switch, so the compiled code evaluates the
Jacobian and its factorisation only at the steps that renew. The state carries the count of
renewals (``jacobians`` in the statistics).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ..errors import Rrr4Error
from .base import FixedStepIntegrator, Run, System, frame_inputs
from .implicit import second_order_split

__all__ = ["Ros2", "GAMMA", "HOLD", "w_matrix"]

GAMMA = 1 + 1 / np.sqrt(2)  # L-stable choice
# steps one Jacobian is held at most: on the reference scene at 1e-4 s, 5 costs 0.6 of a new Jacobian every
# step for 1.5 x its error; 20 to 100, 6-7 x its error; 1000 blows up (benchmarks/bench_default.py)
HOLD = 5
EXTRA = ("jacobians", "age", "matrix_step", "renew")  # state entries after [t, y, z], before A_q and the factors


class _Matrix:
    """The linear algebra of one system, built once: `renew` (t, y, z, u, c) -> [A_q nonzeros,
    QR factors of G]; `solve` (r, m, c) -> k, the solution of (I - c J) k = r."""

    def __init__(self, system: System, nq: int):
        ny, nz, nu = system.ny, system.nz, system.nu
        t, y, z, u, c = ca.SX.sym("t"), ca.SX.sym("y", ny), ca.SX.sym("z", nz), ca.SX.sym("u", nu), ca.SX.sym("c")
        a = system.ode(t, y, z, u)[nq:2 * nq]
        a_q, a_v = ca.jacobian(a, y[:nq]), ca.jacobian(a, y[nq:2 * nq])
        g = ca.SX.eye(nq) - c * (a_v + c * a_q)
        V, R, beta, prinv, pc = ca.qr_sparse(g)
        m = ca.vertcat(*a_q.nonzeros(), *V.nonzeros(), *R.nonzeros(), beta)
        self.size = m.shape[0]
        self.renew = ca.Function("jacobian_factor", [t, y, z, u, c], ca.cse([m]), ["t", "y", "z", "u", "c"], ["m"])

        r, ms = ca.SX.sym("r", ny), ca.SX.sym("m", self.size)
        sizes = np.cumsum([0, a_q.nnz(), V.nnz(), R.nnz()])
        aq = ca.SX(a_q.sparsity(), ms[sizes[0]:sizes[1]])
        Vs, Rs = ca.SX(V.sparsity(), ms[sizes[1]:sizes[2]]), ca.SX(R.sparsity(), ms[sizes[2]:sizes[3]])
        r_q, r_v = r[:nq], r[nq:2 * nq]
        k_v = ca.qr_solve(r_v + c * ca.mtimes(aq, r_q), Vs, Rs, ms[sizes[3]:], prinv, pc)
        self.solve = ca.Function("w_solve", [r, ms, c], ca.cse([ca.vertcat(r_q + c * k_v, k_v, r[2 * nq:])]),
                                 ["r", "m", "c"], ["k"])


def w_matrix(system: System, nq: int) -> _Matrix:
    """The linear algebra of a system (built once per system, kept on it)."""
    key = ("w-matrix", nq)
    if key not in system.frames:
        system.frames[key] = _Matrix(system, nq)
    return system.frames[key]


class Ros2(FixedStepIntegrator):
    """hold: steps one Jacobian is used for at most (1: a new one every step); gamma: the
    diagonal coefficient (L-stable at 1 +- 1/sqrt(2); the larger root measured 7 x more
    accurate on the reference scene)."""
    name = "ros2"
    order = 2

    def __init__(self, jit: bool = False, refine: int = 1, hold: int = HOLD, gamma: float = GAMMA):
        super().__init__(jit=jit, refine=refine)
        if not (isinstance(gamma, (int, float)) and gamma >= 0.25):
            raise Rrr4Error(f"ros2 gamma: {gamma!r} is not allowed (>= 1/4 for A-stability; L-stable at "
                            "1 +- 1/sqrt(2))")
        self.gamma = float(gamma)
        if int(hold) != hold or hold < 1:
            raise Rrr4Error(f"ros2 hold: {hold!r} is not allowed (steps a Jacobian is held, an integer >= 1)")
        self.hold = int(hold)

    @classmethod
    def from_settings(cls, settings, jit: bool = False):
        """integrator.newton 'full': a new Jacobian every step; 'simplified' (default): held (see HOLD)."""
        return cls(jit=jit, refine=settings.refine, hold=1 if settings.newton == "full" else HOLD)

    def advance(self, ode, t, y, z, u, h):  # the matrix-free interface of FixedStepIntegrator
        raise NotImplementedError("ros2 steps through step_function")

    def step_function(self, system: System, h: float) -> ca.Function:
        """MX Function 'step': x = [t, y, z, jacobians, age, matrix step, renew, matrix], u -> x_next."""
        nq = second_order_split(system)
        mat = w_matrix(system, nq)
        ny, nz = system.ny, system.nz
        x, u = ca.MX.sym("x", 1 + ny + nz + len(EXTRA) + mat.size), ca.MX.sym("u", system.nu)
        t, y, z = x[0], x[1:1 + ny], x[1 + ny:1 + ny + nz]
        o = 1 + ny + nz
        jacobians, age, matrix_step, renew = ca.vertsplit(x[o:o + len(EXTRA)])
        m = x[o + len(EXTRA):]
        c = self.gamma * h
        stale = ca.logic_or(ca.logic_or(renew, age >= self.hold), matrix_step != c)
        ins = [ca.MX.sym(n, s) for n, s in (("t", 1), ("y", ny), ("z", nz), ("u", system.nu), ("m", mat.size))]
        keep = ca.Function("jacobian_kept", ins, [ins[-1]])
        fresh = ca.Function("jacobian_renewed", ins, [mat.renew(*ins[:4], c)])
        m = ca.Function.if_else("jacobian_switch", fresh, keep)(stale, t, y, z, u, m)

        # one step from (t, y) with the matrix m: y1, z1 and whether a contact opened or closed
        ts, ys, zs, us, ms = ins
        f0 = system.ode(ts, ys, zs, us)
        k1 = mat.solve(f0, ms, c)
        f1 = system.ode(ts + h, ys + h * k1, zs, us)
        k2 = mat.solve(f1 - 2 * k1, ms, c)
        y1 = ys + h * (1.5 * k1 + 0.5 * k2)
        z1 = system.update(ts + h, y1, zs, us)
        ne = system.events
        changed = ca.norm_inf(z1[:ne] - zs[:ne]) > 0 if ne else ca.MX(0)
        stages = ca.Function("w_stages", ins, [y1, z1, changed], ["t", "y", "z", "u", "m"], ["y1", "z1", "changed"])
        y1, z1, changed = stages(t, y, z, u, m)
        # a contact that opened or closed inside the step: the step again with the matrix at its
        # end, where the contact stiffness the step met is (else the step treats it explicitly)
        ins1 = [*ins, ca.MX.sym("y1", ny), ca.MX.sym("z1", nz), ca.MX.sym("changed")]
        m1 = mat.renew(ins[0] + h, ins1[5], ins[2], ins[3], c)
        redo = ca.Function("event_redone", ins1, [*stages(*ins[:4], m1), m1, ca.MX(1)])
        kept = ca.Function("event_free", ins1, [*ins1[5:], ins[4], ca.MX(0)])
        y1, z1, changed, m, again = ca.Function.if_else("event_switch", redo, kept)(changed, t, y, z, u, m, y1, z1,
                                                                                    changed)
        x1 = ca.vertcat(t + h, y1, z1, jacobians + stale + again, ca.if_else(ca.logic_or(stale, again), 1, age + 1),
                        ca.if_else(stale, c, matrix_step), changed, m)
        return ca.Function("step", [x, u], [x1], ["x", "u"], ["x_next"])

    def run(self, system: System, x0, u_frames, h: float, steps_per_frame: int, chunk: int | None = None,
            progress: bool = False, every: int = 1, sink=None) -> Run:
        """As :meth:`FixedStepIntegrator.run`, with the Jacobian renewals in the statistics."""
        x0 = np.asarray(x0, float)
        u_frames = frame_inputs(u_frames)
        mat = w_matrix(system, second_order_split(system))
        extra = np.zeros(len(EXTRA) + mat.size)
        extra[EXTRA.index("renew")] = 1.0
        states, last, stepping = self.roll(system, np.r_[x0, extra], u_frames, h, steps_per_frame, chunk, progress,
                                           every=every, sink=sink)
        n_steps = steps_per_frame * u_frames.shape[0]
        jacobians = int(round(last[x0.size + EXTRA.index("jacobians")]))
        return Run(states, {"hold": self.hold, "jacobians": jacobians,
                            "jacobians_per_step": jacobians / max(n_steps, 1), "stepping": stepping})

"""The point-to-point formulation of any graph with a task (a body: 3 task coordinates, a
point: 2), on the graph's own equations (:mod:`rrr4.optimal.point_to_point` drives it).

Unknowns at every node: the body coordinates q and rates qd (tied to the task's pose and rate by
the closure and velocity rows), and per side of the node (the acceleration of the interval after
it, and of the one before it) the accelerations qdd, the joint multipliers lambda and the
efforts u, tied by the acceleration rows and

    M qdd + Phi_q^T lambda = Q_g + Q_e(q, qd) + S^T u,

Q_e the known force elements (:attr:`rrr4.problem.Problem.known_forces`): the equations whose
solution set is :meth:`rrr4.problem.Problem.effort_family` (the same family the time law uses).

The contact condition is the preload layer's: sigma d_j . r_j >= f_min, d_j the direction of
joint j's reaction along the (first) null-space direction. The null space of [Phi_q^T, -S^T]
enters as unknowns W ((rows + n) x m per node) with [Phi_q^T, -S^T] W = 0 and Z^T W_u = I,
Z the warm start's orthonormal effort directions at the node (so W's sign is the family's, and
sigma means what it means in the time law). The singularity margin: Y (nq x k) with
Phi_full Y = [0; I] (the velocity analysis), J = S Y, and
tr(G) tr(G^-1) <= path.max_condition_number^2, G = J^T J (the bound of the condition number
the n-RRR formulation constrains), at the nodes and at the points between them (there with q
unknown too, closed on the pose of the constant-acceleration motion).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ..errors import InfeasibleError, KinematicsError
from ..mechanism.workspace import condition_number
from ..problem import Problem
from .motion_check import margin_report

__all__ = ["GraphMotion"]


class GraphMotion:
    """Any graph with a task: body coordinates, multipliers and efforts as unknowns."""

    def __init__(self, problem: Problem, contact: bool):
        self.problem, self.mech, self.model = problem, problem.mechanism, problem.model
        mech, model = self.mech, self.model
        self.k, self.nq = mech.n_task, model.nq
        self.rows = self.nq - self.k
        self.n, self.m_all = model.n_actuators, model.redundancy
        self.m = self.m_all if contact else 0   # null-space unknowns only for the contact condition
        self.functions = problem.memo(("point_to_point", "graph", self.m), self._build)
        self.inner_q = self.inner_y = None

    def _build(self):
        mech, model, nq, k, rows, n, m = self.mech, self.model, self.nq, self.k, self.rows, self.n, self.m
        q, qd, qdd = (ca.SX.sym(s, nq) for s in ("q", "qd", "qdd"))
        task, task_d, task_dd = (ca.SX.sym(s, k) for s in ("task", "task_d", "task_dd"))
        lam, u = ca.SX.sym("lambda", rows), ca.SX.sym("u", n)
        A, gamma, _, S = mech.constraint_jacobian_function(q, qd)
        pad = ca.SX.zeros(rows)
        closure = mech.closure_function(q, ca.vertcat(task, pad))
        kin = ca.Function("motion_kinematics", [q, qd, task, task_d],
                          [ca.vertcat(closure, A @ qd - ca.vertcat(pad, task_d))])
        M = ca.DM(model.mass_diagonal)
        Q = ca.DM(model.gravity_forces(self.problem.gravity))
        forces = self.problem.known_forces
        if forces is not None:
            Q = Q + forces(q, qd, 0.0)
        dyn = ca.Function("motion_dynamics", [q, qd, qdd, task_dd, lam, u],
                          [ca.vertcat(A @ qdd - gamma - ca.vertcat(pad, task_dd),
                                      M * qdd + A[:rows, :].T @ lam - Q - S.T @ u)])
        Y = ca.SX.sym("Y", nq, k)
        J = S @ Y
        G = J.T @ J
        E = ca.vertcat(ca.SX.zeros(rows, k), ca.SX.eye(k))
        margin = ca.Function("motion_margin", [q, ca.vec(Y)],
                             [ca.vec(A @ Y - E), ca.trace(G) * ca.trace(ca.inv(G))])
        out = {"kinematics": kin, "dynamics": dyn, "margin": margin,
               "closure": ca.Function("motion_closure", [q, task], [closure])}
        if m:
            W, Z = ca.SX.sym("W", rows + n, m), ca.SX.sym("Z", n, m)
            nul = ca.vertcat(ca.vec(A[:rows, :].T @ W[:rows, :] - S.T @ W[rows:, :]),
                             ca.vec(Z.T @ W[rows:, :] - ca.SX.eye(m)))
            idx = [2 * model.joint_names.index(j) + c for j in model.preload_joints for c in (0, 1)]
            w = ca.reshape(W[idx, 0], 2, -1)
            x = ca.reshape(lam[idx], 2, -1)
            axial = (ca.sum1(w * x) / ca.sqrt(ca.sum1(w**2) + 1e-300)).T
            out["null"] = ca.Function("motion_null", [q, ca.vec(W), ca.vec(Z)], [nul])
            out["axial"] = ca.Function("motion_axial", [ca.vec(W), lam], [axial])
        return out

    # ------------------------------------------------------------------ checks of the ends

    def check_pose(self, key: str, pose):
        try:
            q = self.mech.assemble(np.asarray(pose, float)[:self.k])
        except KinematicsError as e:
            raise KinematicsError(f"{key}: {e}") from None
        cond = float(condition_number(self.mech.path_jacobians(q[None]))[0])
        cmax = self.problem.path.max_condition_number
        if not cond <= cmax:
            raise InfeasibleError(f"{key} pose {np.round(pose, 6).tolist()} is beyond the singularity margin: "
                                  f"condition number of J {cond:.4g} (allowed <= path.max_condition_number = {cmax:g})")

    def margins(self, t, pose, q) -> dict:
        """The condition number's extreme at the samples (t, q (K, nq)) and its first violation."""
        return margin_report(t, condition_number(self.mech.path_jacobians(q)), self.problem.path.max_condition_number)

    # ------------------------------------------------------------------ the program

    def unknowns(self, opti, N):
        N1, nq = N + 1, self.nq
        v = {"q": opti.variable(nq, N1), "qd": opti.variable(nq, N1), "Y": opti.variable(nq * self.k, N1)}
        for s in (0, 1):
            v[f"qdd{s}"] = opti.variable(nq, N1)
            v[f"lambda{s}"] = opti.variable(self.rows, N1)
            v[f"u{s}"] = opti.variable(self.n, N1)
        if self.m:
            v["W"] = opti.variable((self.rows + self.n) * self.m, N1)
            v["Z"] = opti.parameter(self.n * self.m, N1)
        return v

    def nodes(self, rows, v, task, task_d, sides):
        """The equations at the nodes; the efforts and the contact components of each side."""
        N1, nq, f = task.shape[1], self.nq, self.functions
        rows.add(f["kinematics"].map(N1)(v["q"], v["qd"], task, task_d), 0.0, 0.0,
                 [f"position closure row {i}" for i in range(nq)] + [f"velocity closure row {i}" for i in range(nq)])
        for s, acc in enumerate(sides):
            rows.add(f["dynamics"].map(N1)(v["q"], v["qd"], v[f"qdd{s}"], acc, v[f"lambda{s}"], v[f"u{s}"]), 0.0, 0.0,
                     [f"acceleration closure row {i}" for i in range(nq)]
                     + [f"equation of motion row {i}" for i in range(nq)])
        self._margin(rows, v["q"], v["Y"], "node")
        axials = [ca.MX(0, N1), ca.MX(0, N1)]
        if self.m:
            rows.add(f["null"].map(N1)(v["q"], v["W"], v["Z"]), 0.0, 0.0,
                     [f"null space row {i}" for i in range(nq * self.m + self.m**2)])
            axials = [f["axial"].map(N1)(v["W"], v[f"lambda{s}"]) for s in (0, 1)]
        return [v["u0"], v["u1"]], axials

    def _margin(self, rows, q, Y, where):
        K = q.shape[1]
        res, bound2 = self.functions["margin"].map(K)(q, Y)
        rows.add(res, 0.0, 0.0, [f"velocity analysis row {i}" for i in range(self.nq * self.k)], where)
        rows.add(bound2 / self.problem.path.max_condition_number**2, None, 1.0, ["condition number"], where)

    def between(self, rows, poses):
        """The singularity margin at task poses (k, K) between the nodes (q and Y unknown there)."""
        K = poses.shape[1]
        self.inner_q, self.inner_y = rows.opti.variable(self.nq, K), rows.opti.variable(self.nq * self.k, K)
        rows.add(self.functions["closure"].map(K)(self.inner_q, poses), 0.0, 0.0,
                 [f"position closure row {i}" for i in range(self.nq)], "point between nodes")
        self._margin(rows, self.inner_q, self.inner_y, "point between nodes")

    def initial(self, opti, v, warm):
        """The warm start's body motion, its efforts (the law's alpha in the family), the
        multipliers that balance them, the null space and the velocity analysis; Z."""
        k, problem, mech = self.k, self.problem, self.mech
        pose, pose_d = warm["pose"], warm["pose_d"]
        acc = warm["sides"]
        q = problem.path_coordinates(pose, pose_d, acc[0])
        opti.set_initial(v["q"], q.T)
        V, S = mech.velocity_maps(q)
        opti.set_initial(v["Y"], V.transpose(0, 2, 1).reshape(len(q), -1).T)
        fams = [problem.effort_family(pose, pose_d, a, q=q) for a in acc]
        Z = fams[0].tau_n[:, :, :self.m]
        for s, a in enumerate(acc):
            qd, qdd, _, _ = mech.motion(q, pose_d[:, :k], a[:, :k])
            if s == 0:
                opti.set_initial(v["qd"], qd.T)
            u = fams[s].tau_p + np.einsum("knm,km->kn", fams[s].tau_n, warm["alpha"])
            opti.set_initial(v[f"qdd{s}"], qdd.T)
            opti.set_initial(v[f"u{s}"], u.T)
            opti.set_initial(v[f"lambda{s}"], self._multipliers(q, qd, qdd, u).T)
        if self.m:
            opti.set_value(v["Z"], Z.transpose(0, 2, 1).reshape(len(q), -1).T)
            opti.set_initial(v["W"], self._null(q, Z).T)
        if self.inner_q is not None:
            qi = problem.path_coordinates(warm["inner_pose"], np.zeros_like(warm["inner_pose"]),
                                          np.zeros_like(warm["inner_pose"]))
            Vi, _ = mech.velocity_maps(qi)
            opti.set_initial(self.inner_q, qi.T)
            opti.set_initial(self.inner_y, Vi.transpose(0, 2, 1).reshape(len(qi), -1).T)

    def _matrices(self, q):
        """(Phi_q^T of the joint rows (N, nq, rows), S^T (N, nq, n)) at q (N, nq)."""
        N = len(q)
        Phi, _, _, S = (np.array(x).reshape(x.shape[0], N, x.shape[1] // N).transpose(1, 0, 2)
                        for x in self.mech.constraint_jacobian_function.map(N)(q.T, np.zeros((self.nq, N))))
        return Phi[:, :self.rows, :].transpose(0, 2, 1), S.transpose(0, 2, 1)

    def _multipliers(self, q, qd, qdd, u):
        """lambda (N, rows) that balance the efforts u (least squares)."""
        PhiT, ST = self._matrices(q)
        Q = self.model.gravity_forces(self.problem.gravity)[None, :] - qdd * self.model.mass_diagonal
        forces = self.problem.known_forces
        if forces is not None:
            Q = Q + np.array(forces.map(len(q))(q.T, qd.T, 0.0)).T
        b = Q + np.einsum("kij,kj->ki", ST, u)
        return np.stack([np.linalg.lstsq(PhiT[i], b[i], rcond=None)[0] for i in range(len(q))])

    def _null(self, q, Z):
        """W (N, (rows + n) m) with [Phi_q^T, -S^T] W = 0 and Z^T W_u = I."""
        PhiT, ST = self._matrices(q)
        A = np.concatenate([PhiT, -ST], axis=2)
        _, _, Vt = np.linalg.svd(A)
        Nsp = Vt[:, Vt.shape[1] - self.m:, :].transpose(0, 2, 1)
        W = np.einsum("kij,kjl->kil", Nsp, np.linalg.inv(np.einsum("knm,knl->kml", Z, Nsp[:, self.rows:, :])))
        return W.transpose(0, 2, 1).reshape(len(q), -1)

    def values(self, sol, v, pose3, pose_d3, sides3):
        """Per side: efforts (N+1, n), reactions (N+1, nj, 2) and the contact components
        (N+1, nj) (from the family of the solution's q, the mechanism's own evaluation); alpha
        (N+1, m_all); condition (N+1,) of the solution's q; transmission None; the bound of the
        condition number (N+1,)."""
        N1 = pose3.shape[1]
        q = np.atleast_2d(sol.value(v["q"])).reshape(self.nq, N1).T
        out, alphas = [], []
        for s in (0, 1):
            u = np.atleast_2d(sol.value(v[f"u{s}"])).reshape(self.n, N1).T
            fam = self.problem.effort_family(pose3.T, pose_d3.T, np.asarray(sides3[s]).T, q=q)
            alpha = np.stack([np.linalg.lstsq(fam.tau_n[i], u[i] - fam.tau_p[i], rcond=None)[0] for i in range(N1)])
            r = fam.r_p + np.einsum("kjcm,km->kjc", fam.r_n, alpha)
            d = fam.r_n[..., 0] if self.m_all else np.zeros_like(r)
            d = d / np.maximum(np.linalg.norm(d, axis=-1, keepdims=True), 1e-300)
            out.append((u, r, np.einsum("kjc,kjc->kj", d, r) if self.m else np.zeros((N1, 0))))
            alphas.append(alpha)
        J = self.mech.path_jacobians(q)
        G = np.einsum("kni,knj->kij", J, J)
        bound = np.sqrt(np.trace(G, axis1=1, axis2=2) * np.trace(np.linalg.inv(G), axis1=1, axis2=2))
        return out, alphas[0], condition_number(J), None, bound

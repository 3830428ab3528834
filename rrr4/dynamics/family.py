"""The affine family of actuator efforts and joint reactions along a task motion.

For the ideal mechanism, M qdd + Phi_q^T lambda = Q_g + S^T u (Nikravesh 1988, ch. 6;
S = d(actuator coordinates)/dq) fixes (u, lambda) up to the null space of
A = [Phi_q^T, -S^T], whose dimension is the degree of actuation redundancy m:

    u = u_p + N alpha,     r_j = r_p,j + sum_k alpha_k r_n,j,k,

with u_p orthogonal to the columns of N (the minimum-norm efforts) and N orthonormal. The
preload layer only ever sees this family (:class:`EffortFamily`; ``Problem.effort_family``
picks the source). An n-RRR scene uses its closed form (:mod:`rrr4.dynamics.inverse`); any
other graph gets it here from one batched
SVD per path (numpy), with the sign of a one-dimensional null space kept continuous along
the path (for m >= 2 the basis of every sample is rotated onto the previous one's, so
alpha means the same along the path). Reactions are those of the passive revolute joints (``Model.preload_joints``),
force of the inboard on the outboard body [N], global frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mechanism import Mechanism, Model

__all__ = ["EffortFamily", "graph_family"]


@dataclass(frozen=True)
class EffortFamily:
    """tau_p (N, n) [N m or N]; tau_n (N, n, m); r_p (N, nj, 2) [N]; r_n (N, nj, 2, m)."""
    tau_p: np.ndarray
    tau_n: np.ndarray
    r_p: np.ndarray
    r_n: np.ndarray

    @property
    def raw(self) -> list[np.ndarray]:
        """The family as inputs of a mapped preload Function (tau_p, tau_n, r_p, r_n, one
        sample after the other: (n, N), (n, N m), (2, N nj), (2, N m nj))."""
        N, n, m = self.tau_n.shape
        nj = self.r_p.shape[1]
        return [self.tau_p.T, self.tau_n.transpose(1, 0, 2).reshape(n, N * m),
                self.r_p.transpose(2, 0, 1).reshape(2, N * nj),
                self.r_n.transpose(2, 0, 3, 1).reshape(2, N * m * nj)]

    def plus(self, other: EffortFamily) -> EffortFamily:
        """This family with `other`'s particular efforts and reactions added: the family of the
        summed loads, for `other` of the same mechanism and poses (its null part is ignored)."""
        return EffortFamily(self.tau_p + other.tau_p, self.tau_n, self.r_p + other.r_p, self.r_n)

    @staticmethod
    def from_raw(raw) -> EffortFamily:
        """Inverse of :attr:`raw` for the outputs of a mapped 'inverse_dynamics' Function."""
        tp, tn, rp, rn = (np.asarray(v, float) for v in raw)
        n, N = tp.shape
        m = tn.shape[1] // N
        nj = rp.shape[1] // N
        return EffortFamily(tp.T, tn.reshape(n, N, m).transpose(1, 0, 2),
                            rp.reshape(2, N, nj).transpose(1, 2, 0),
                            rn.reshape(2, N, m, nj).transpose(1, 3, 0, 2))


def graph_family(mech: Mechanism, q: np.ndarray, qdd: np.ndarray, gravity, external=None) -> EffortFamily:
    """The family of any graph from q, qdd (N, nq) of its ideal motion (all joints closed).
    Without a task body the drivers' reactions join the joints' (their rows follow).
    external (N, nq) [N, N m]: generalised forces of the force elements at the samples
    (``Problem.element_forces``), balanced by the efforts and reactions like gravity."""
    model: Model = mech.model
    N, nq = q.shape
    n, m = model.n_actuators, model.redundancy
    Phi_q, _, _, S = (np.array(v).reshape(v.shape[0], N, v.shape[1] // N).transpose(1, 0, 2)
                      for v in mech.constraint_jacobian_function.map(N)(np.asarray(q).T, np.zeros((nq, N))))
    rows = 2 * len(model.joint_names) + (0 if model.task else len(model.graph.drivers))
    Phi_q = Phi_q[:, :rows]
    A = np.concatenate([Phi_q.transpose(0, 2, 1), -S.transpose(0, 2, 1)], axis=2)   # (N, nq, rows + n)
    b = model.gravity_forces(gravity)[None, :] - qdd * model.mass_diagonal[None, :]
    if external is not None:
        b = b + np.asarray(external, float)
    _, sv, Vt = np.linalg.svd(A)
    x0 = np.einsum("kij,kj->ki", np.linalg.pinv(A), b)
    Nsp = Vt[:, Vt.shape[1] - m:, :].transpose(0, 2, 1) if m else np.zeros((N, rows + n, 0))   # (N, rows + n, m)
    Nu = Nsp[:, rows:, :]
    if m:
        # minimum-norm efforts: remove the null-space part of u0; orthonormal effort directions
        a0 = -np.einsum("kij,kj->ki", np.linalg.pinv(Nu), x0[:, rows:])
        x0 = x0 + np.einsum("kij,kj->ki", Nsp, a0)
        Qm, R = np.linalg.qr(Nu)
        Nsp = np.einsum("kij,kjl->kil", Nsp, np.linalg.inv(R))
        # keep the basis continuous along the path: rotate each sample's orthonormal effort
        # directions onto the previous sample's (orthogonal Procrustes; a sign for m = 1)
        for k in range(1, N):
            u, _, vt = np.linalg.svd(Nsp[k, rows:, :].T @ Nsp[k - 1, rows:, :])
            Nsp[k] = Nsp[k] @ (u @ vt)
    idx = [2 * model.joint_names.index(j) + c for j in model.preload_joints for c in (0, 1)]
    nj = len(model.preload_joints)
    r_p = -x0[:, idx].reshape(N, nj, 2)
    r_n = -Nsp[:, idx, :].reshape(N, nj, 2, m)
    return EffortFamily(x0[:, rows:], Nsp[:, rows:, :], r_p, r_n)

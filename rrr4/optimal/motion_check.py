"""A point-to-point motion checked along its whole length, not only at its nodes.

The motion as transcribed (constant task acceleration on each interval) is sampled between the
nodes (:func:`along_motion`); at every sample the mechanism's own kinematics (the closed form of
an n-RRR, Newton continuation for a graph) and the problem's effort family
(:meth:`rrr4.problem.Problem.effort_family`, not the optimal-control program's expressions)
give the singularity margins, the efforts and the passive joints' reactions. The null-space
efforts between two nodes are the plan's: linear in time from the node's value (with the
acceleration of the interval after it) to the next node's (with the interval's own), each found
from the node's efforts in the family at the sample. :func:`plan_report` gives the efforts'
peak ratio to their limits and the smallest contact margin, with the first violation.
"""

from __future__ import annotations

import numpy as np

from ..problem import Problem
from .time_law import contact_directions

__all__ = ["along_motion", "margin_report", "plan_report", "MARGIN_TOL", "MIN_SAMPLES_PER_INTERVAL",
           "MAX_ALONG_SAMPLES"]

MIN_SAMPLES_PER_INTERVAL, MAX_ALONG_SAMPLES = 32, 100_000
MARGIN_TOL = 1e-6  # relative tolerance of the checks


def along_motion(motion, rate: float, least: int = MIN_SAMPLES_PER_INTERVAL):
    """t (K,), pose, pose_d, pose_dd (K, 3), interval (K,) and the fraction u/h in it (K,): the
    motion between its nodes as transcribed (constant acceleration on each interval), sampled
    at `rate` [Hz] (at most MAX_ALONG_SAMPLES in all) and at least `least` instants per
    interval, the nodes included (the last node as the end of the last interval)."""
    N = len(motion.t) - 1
    h = motion.duration / N
    k = max(least, min(int(np.ceil(h * rate)), MAX_ALONG_SAMPLES // N))
    frac = np.r_[np.arange(k) / k]
    u = frac * h
    p0, v0, a = motion.pose[:-1, None, :], motion.pose_d[:-1, None, :], motion.pose_dd[:-1, None, :]
    pose = (p0 + u[None, :, None] * v0 + 0.5 * u[None, :, None]**2 * a).reshape(-1, 3)
    pose_d = (v0 + u[None, :, None] * a).reshape(-1, 3)
    pose_dd = np.broadcast_to(a, (N, k, 3)).reshape(-1, 3)
    t = (motion.t[:-1, None] + u[None, :]).ravel()
    interval = np.repeat(np.arange(N), k)
    fr = np.tile(frac, N)
    return (np.r_[t, motion.t[-1]], np.vstack([pose, motion.pose[-1]]), np.vstack([pose_d, motion.pose_d[-1]]),
            np.vstack([pose_dd, motion.pose_dd[-2]]), np.r_[interval, N - 1], np.r_[fr, 1.0])


def margin_report(t, cond, cmax, sin_tr=None, tmin=None) -> dict:
    """The extremes of the singularity margins at the samples t and their first violation
    ('' if none)."""
    out = {"samples": int(t.size), "max_condition_number": float(np.max(cond)),
           "t_max_condition_s": float(t[int(np.argmax(cond))]), "violation": "", "margin_violation": False}
    if sin_tr is not None:
        low = np.min(sin_tr, axis=1)
        out.update(min_transmission=float(np.min(low)), t_min_transmission_s=float(t[int(np.argmin(low))]))
        if out["min_transmission"] < tmin * (1 - MARGIN_TOL):
            out["violation"] = (f"a transmission |sin| of {out['min_transmission']:.3g} at t = "
                                f"{out['t_min_transmission_s']:.4g} s (allowed >= path.min_transmission = {tmin:g})")
    if not out["max_condition_number"] <= cmax * (1 + MARGIN_TOL):
        out["violation"] = (f"a condition number of J of {out['max_condition_number']:.4g} at t = "
                            f"{out['t_max_condition_s']:.4g} s (allowed <= path.max_condition_number = {cmax:g})")
    out["margin_violation"] = bool(out["violation"])
    return out


def plan_report(problem: Problem, motion, samples, q) -> dict:
    """The planned efforts and the contact condition at the samples of :func:`along_motion`
    (q (K, nq): the body coordinates there): the peak of |effort| / limit, the smallest
    sigma d_j . r_j - f_min [N] (with the contact condition), where, and the first violation."""
    t, pose, pose_d, pose_dd, interval, frac = samples
    N = len(motion.t) - 1
    fam = problem.effort_family(pose, pose_d, pose_dd, q=q)
    nodes = np.r_[np.flatnonzero(frac == 0.0), len(t) - 1]   # node k at sample nodes[k]
    m = fam.tau_n.shape[2]
    alpha = np.zeros((len(t), m))
    if m:
        # the node's alpha in the family at the sample: after (interval k) and before (interval k - 1) it
        before = problem.effort_family(motion.pose, motion.pose_d, np.r_[motion.pose_dd[:1], motion.pose_dd[:-1]],
                                       q=q[nodes])
        a_after = _alpha(fam.tau_n[nodes], fam.tau_p[nodes], motion.efforts)
        a_before = _alpha(fam.tau_n[nodes], before.tau_p, motion.efforts_before)
        alpha = a_after[interval] + frac[:, None] * (a_before[interval + 1] - a_after[interval])
    tau = fam.tau_p + np.einsum("knm,km->kn", fam.tau_n, alpha)
    L = np.asarray(problem.torque_limit, float)
    ratio = np.max(np.abs(tau) / L, axis=1)
    i = int(np.argmax(ratio))
    out = {"peak_effort_ratio": float(ratio[i]), "t_peak_effort_s": float(t[i]), "limit_violation": False,
           "contact_violation": False, "violation": ""}
    if ratio[i] > 1 + MARGIN_TOL:
        out["limit_violation"] = True
        out["violation"] = (f"an effort of {ratio[i]:.6g} times its limit at t = {t[i]:.4g} s (allowed <= 1, "
                            f"actuator {problem.model.actuator_names[int(np.argmax(np.abs(tau[i]) / L))]})")
    if motion.contact and m:
        r = fam.r_p + np.einsum("kjcm,km->kjc", fam.r_n, alpha)
        axial = motion.sign * np.einsum("kjc,kjc->kj", contact_directions(fam.r_n), r)
        low = np.min(axial, axis=1)
        i = int(np.argmin(low))
        out.update(min_contact_margin_N=float(low[i] - motion.f_min), t_min_contact_margin_s=float(t[i]))
        if low[i] < motion.f_min * (1 - MARGIN_TOL):
            out["contact_violation"] = True
            j = problem.model.preload_joints[int(np.argmin(axial[i]))]
            out["violation"] = out["violation"] or (f"a contact force of {low[i]:.6g} N at joint {j} at t = "
                                                    f"{t[i]:.4g} s (allowed >= f_min = {motion.f_min:g} N)")
    out["nodes"] = N + 1
    return out


def _alpha(tau_n, tau_p, tau) -> np.ndarray:
    """alpha (N, m) with tau = tau_p + tau_n alpha (least squares) at each of N samples."""
    return np.stack([np.linalg.lstsq(tau_n[k], tau[k] - tau_p[k], rcond=None)[0] for k in range(len(tau))])

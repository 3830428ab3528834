"""Method 'seated': the quasi-static model of a preloaded n-RRR (DESIGN sections 7 and 11).

Under preload each clearance journal is seated where its reaction pushes it
(:func:`rrr4.control.compensation.seats`): its gap is a smooth function of the clearance,
the contact stiffness and the friction coefficient. With the actuators at their measured
angles theta (or, without them, at the controller's references) the task body sits where
the chains close around those gaps: the least-squares forward kinematics of the n chains
(two Gauss-Newton steps from the reference pose; the offsets are ~1e-4 m, so the error is
~1e-4^2 / l, below 0.1 um). The efforts carry the seated journals' friction moments: the
part of the measured efforts outside the preload direction tau_n is the inverse dynamics
plus the minimum-norm effort that overcomes them (:func:`rrr4.control.compensation.friction_feed_forward`),
so the preload, whatever the controller made of it, drops out (variable projection). A
friction moment that reverses is taken up by the feedback's position error while the
journal sticks: the friction efforts follow the model through a first-order lag of the
feedback's kd / kp (``effort_lag``).

:func:`seated_model` is one SX Function per problem structure and parameter layout:
pose_ref, pose_d (3 each), theta (n), r (2, nj), p (np) -> pose (3), tau_friction (n) and
their Jacobians in p. The reactions r are those of the ideal mechanism at the desired
motion with the preload alpha the mechanism carries: the measured efforts' part along tau_n
(where all efforts are measured; the controller's feedback changes the preload it plans),
else the measured ``alpha_Nm``, else the controller's.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ..control.compensation import friction_feed_forward, nrrr_slip, seats, slip_rows
from ..control.references import path_rows, tabulated
from ..errors import MeasurementError, SceneError
from ..problem import Problem
from .measurements import Measurements, measurement_columns
from .parameters import Parameter

__all__ = ["seated_model", "SeatedData", "noise_from_residuals", "seated_measurements", "first_order_lag",
           "effort_lag_of", "GN_STEPS", "check_friction_explained", "FRICTION_EXPLAINED_MIN",
           "SLIDING_MIN", "check_seated"]

GN_STEPS = 2  # Gauss-Newton steps of the forward kinematics from the reference pose
GRAPH_ITERATIONS = 3  # chord iterations of a graph's closure around its seats (each gains ~1e-4)
# the least ratio of the friction efforts the seated model explains to the systematic effort residual
# it leaves (:func:`check_friction_explained`): 3.5, i.e. the model accounts for ~92 % of the efforts
# off the preload. Measured on the reference run's with_preload arm (true friction 0.1), from t = 0 to
# 0.05 s: 0.12 (friction 0.003); 0.1 s: 2.2 (0.058); 0.2 s: 3.1 (0.086); 0.3 s: 4.7 (0.096); 1 s:
# 4.5 (0.099)
FRICTION_EXPLAINED_MIN = 3.5
# ... unless the journals slide faster than the friction law's v1 at this fraction of the instants at
# least (0.05 s: 0 %, 0.1 s: 33 %, 0.2 s: 59 %, 1 s: 83 %)
SLIDING_MIN = 0.5


def _layout(params: list[Parameter]) -> tuple:
    return tuple((p.kind, p.joints, p.chain, p.axis) for p in params)


def check_seated(problem: Problem) -> None:
    """SceneError (one line, naming the reason) when method 'seated' cannot model `problem`:
    a driven scene (no task: its motion is prescribed by drivers, nothing seats its journals in a
    known direction) or one without a preload."""
    if problem.model.task is None:
        raise SceneError(f"mechanism.drivers: method 'seated' needs a task body or point that follows the path under "
                         f"preload (scene {problem.name!r} is driven by its drivers): a driven scene needs method "
                         "'dynamic'")
    if not problem.has_preload:
        raise SceneError(f"actuation.preload: method 'seated' needs the journals seated by a preload (scene "
                         f"{problem.name!r} does not preload; method 'dynamic' shoots through the simulation)")


def seated_model(problem: Problem, params: list[Parameter]) -> ca.Function:
    """The seated prediction as an SX Function 'seated_prediction' (see the module docstring),
    built once per problem and parameter layout: the n-RRR's closed form, or any graph with a
    task body or point (:func:`_build_graph`)."""
    check_seated(problem)
    build = _build if problem.closed_form else _build_graph
    return problem.memo(("identify_seated", _layout(params)), lambda: build(problem, params))


def _contact(problem: Problem, params: list[Parameter], p) -> list:
    """The contact vector (``Problem.contact_parameters``) with the parameters p set by name."""
    at = problem.parameter_layout.index
    contact = [ca.SX(v) for v in problem.contact_parameters]
    for i, q in enumerate(params):
        if q.kind == "clearance":
            for j in q.joints:
                contact[at(f"joints.{j}.bearing_radius")] = contact[at(f"joints.{j}.journal_radius")] + p[i]
        elif q.kind == "stiffness":
            for j in problem.clearance_joints:
                contact[at(f"joints.{j}.stiffness")] = p[i]
        elif q.kind == "friction":
            contact[at("contact.friction_coefficient")] = p[i]
    return ca.vertcat(*contact)


def _build_graph(problem: Problem, params: list[Parameter]) -> ca.Function:
    """Any graph with a task: the loops closed around the seats' gaps with the actuators at
    theta, by chord iterations from the ideal coordinates q_ref at the path's pose (the
    closure's Jacobian inverted there, Ainv, and the task's least-squares map from the
    actuators G = pinv(S Ainv[:, task])) given per instant: the offsets are ~1e-4 of the
    links, so each iteration gains ~1e-4. The friction efforts: -P f_t with P = J (J^T J)^-1
    (W V)^T per instant (virtual power, as the graph controller's feed-forward)."""
    model, mech = problem.model, problem.mechanism
    nq, n, k = model.nq, mech.n, mech.n_task
    names = model.preload_joints
    p = ca.SX.sym("p", len(params))
    q_ref, ainv, g = ca.SX.sym("q_ref", nq), ca.SX.sym("Ainv", nq, nq), ca.SX.sym("G", k, n)
    theta, r = ca.SX.sym("theta", n), ca.SX.sym("r", 2, len(names))
    slip, P = ca.SX.sym("slip", len(names)), ca.SX.sym("P", n, len(names))
    friction = problem.scene.effects.friction.law != "none"
    gaps, f_t = seats(problem, r, slip if friction else None, _contact(problem, params, p))
    rows, offset = [], []
    for name in mech.joint_names:
        eq = model.joint_equations(ca.SX.sym("q", nq), name)
        rows.append(eq.numel())
        gap = gaps[:, names.index(name)] if name in problem.clearance_joints else ca.SX.zeros(eq.numel())
        offset.append(gap if eq.numel() == 2 else ca.SX.zeros(eq.numel()))
    offset = ca.vertcat(*offset)

    def closure(q, target):
        eqs = ca.vertcat(*[model.joint_equations(q, j) for j in mech.joint_names])
        return ca.vertcat(eqs - offset, model.task_pose(q)[:k] - target)

    q, target = q_ref, model.task_pose(q_ref)[:k]
    to_task = ainv[:, sum(rows):]
    for _ in range(GRAPH_ITERATIONS):
        q = q - ainv @ closure(q, target)
        d = model.actuator_coordinates_function(q)[0] - theta
        step = -g @ ca.atan2(ca.sin(d), ca.cos(d))
        target, q = target + step, q + to_task @ step
    q = q - ainv @ closure(q, target)
    pose = model.task_pose(q)
    tau_f = -P @ f_t if friction else ca.SX.zeros(n)
    return ca.Function("seated_prediction", [q_ref, ainv, g, slip, P, theta, r, p],
                       [pose, tau_f, ca.jacobian(pose, p), ca.jacobian(tau_f, p)],
                       ["q_ref", "Ainv", "G", "slip", "P", "theta", "r", "p"],
                       ["pose", "tau_friction", "dpose_dp", "dtau_dp"])


def _build(problem: Problem, params: list[Parameter]) -> ca.Function:
    mech = problem.mechanism
    data, n = mech.data, mech.n
    names = problem.model.preload_joints
    p = ca.SX.sym("p", len(params))
    pose_ref, pose_d = ca.SX.sym("pose_ref", 3), ca.SX.sym("pose_d", 3)
    theta, r = ca.SX.sym("theta", n), ca.SX.sym("r", 2, len(names))
    base = [[ca.SX(v) for v in c.base] for c in data.chains]
    l1 = [ca.SX(c.driving.length) for c in data.chains]
    l2 = [ca.SX(c.following.length) for c in data.chains]
    for i, q in enumerate(params):
        if q.kind == "base":
            base[q.chain][q.axis] = p[i]
        elif q.kind in ("driving", "following"):
            (l1 if q.kind == "driving" else l2)[q.chain] = p[i]
    contact = _contact(problem, params, p)
    slip = nrrr_slip(problem, pose_ref, pose_d)
    gaps, f_t = seats(problem, r, slip if problem.scene.effects.friction.law != "none" else None, contact)

    # the chains' IK around their gaps, with the (possibly identified) geometry
    x, shift = ca.SX.sym("x", 3), ca.SX.sym("shift", 2, n)
    th = []
    for i, c in enumerate(data.chains):
        C = x[0:2] + c.attachment_radius * ca.vertcat(ca.cos(x[2] + c.attachment_angle),
                                                       ca.sin(x[2] + c.attachment_angle))
        d = C - ca.vertcat(*base[i]) - shift[:, i]
        dist = ca.norm_2(d)
        cos_arg = (l1[i] ** 2 + dist ** 2 - l2[i] ** 2) / (2 * l1[i] * dist)
        th.append(ca.atan2(d[1], d[0]) + float(mech.modes[i]) * ca.acos(cos_arg))
    th = ca.vertcat(*th)
    ik = ca.Function("seated_ik", [x, shift, p], [th, ca.jacobian(th, x)])
    pose = pose_ref
    shifts = gaps[:, :n] + gaps[:, n:]
    for _ in range(GN_STEPS):
        t_model, jac = ik(pose, shifts, p)
        d = t_model - theta
        res = ca.atan2(ca.sin(d), ca.cos(d))
        pose = pose - ca.solve(jac.T @ jac, jac.T @ res)
    if problem.scene.effects.friction.law != "none":
        tau_f = friction_feed_forward(problem, pose_ref, pose_d, slip, f_t)
    else:
        tau_f = ca.SX.zeros(n)
    return ca.Function("seated_prediction", [pose_ref, pose_d, theta, r, p],
                       [pose, tau_f, ca.jacobian(pose, p), ca.jacobian(tau_f, p)],
                       ["pose_ref", "pose_d", "theta", "r", "p"],
                       ["pose", "tau_friction", "dpose_dp", "dtau_dp"])


def effort_lag_of(problem: Problem, lag) -> float:
    """The time constant [s] of the friction efforts' lag: 'controller' (kd / kp of the scene's
    feedback: a friction moment that reverses is taken up by the feedback's position error,
    which settles with kd / kp while the journal sticks), or a number >= 0."""
    if lag == "controller":
        a = problem.scene.actuation
        return a.kd / a.kp if a.kp > 0 else 0.0
    if isinstance(lag, bool) or not isinstance(lag, (int, float)) or not (lag >= 0 and np.isfinite(lag)):
        raise SceneError(f"effort_lag: {lag!r} is not allowed ('controller' or a time constant >= 0 in s)")
    return float(lag)


def first_order_lag(t: np.ndarray, x: np.ndarray, T: float) -> np.ndarray:
    """x (N, ...) through the first-order lag T y' + y = x (backward Euler on the grid t,
    y_0 = x_0)."""
    y = np.empty_like(x)
    y[0] = x[0]
    for k in range(1, len(t)):
        a = (t[k] - t[k - 1]) / (T + t[k] - t[k - 1])
        y[k] = y[k - 1] + a * (x[k] - y[k - 1])
    return y


class SeatedData:
    """What the seated model needs at the measured instants, computed once: the desired
    motion, the actuator angles (measured, else the controller's references), the reactions
    with the preload, the effort family, and the measured columns."""

    def __init__(self, problem: Problem, m: Measurements, params: list[Parameter], effort_lag="controller"):
        self.problem, self.m, self.params = problem, m, params
        self.lag = effort_lag_of(problem, effort_lag)
        kinds = measurement_columns(problem)
        t = m.t
        path = problem.path
        if t[0] < -1e-12 or t[-1] > path.duration + 1e-9:
            raise MeasurementError(f"{m.source or 'measurements'}: t runs from {t[0]:.6g} s to {t[-1]:.6g} s (the "
                                   f"scene's path runs from 0 to {path.duration:g} s; times are path times)")
        rows = path_rows(path, t)
        self.pose_ref, self.pose_d, pose_dd = rows[:, :3], rows[:, 3:6], rows[:, 6:9]
        self.pose_cols = m.has(kinds["pose"])
        self.effort_cols = m.has(kinds["effort"])
        angles = m.has(kinds["angle"])
        q = None if problem.closed_form else problem.path_coordinates(self.pose_ref, self.pose_d, pose_dd)
        fam = problem.effort_family(self.pose_ref, self.pose_d, pose_dd, q=q)
        n_m = fam.tau_n.shape[2]
        if self.effort_cols and len(self.effort_cols) <= n_m:
            raise MeasurementError(f"{m.source or 'measurements'}: efforts {', '.join(self.effort_cols)} alone carry "
                                   f"nothing beyond the preload (measure at least {n_m + 1} of "
                                   f"{', '.join(kinds['effort'])})")
        if angles and len(angles) != len(kinds["angle"]):
            missing = sorted(set(kinds["angle"]) - set(angles))
            raise MeasurementError(f"{m.source or 'measurements'}: actuator angles {', '.join(missing)} are missing "
                                   "(measure all of them, or none: then the controller's references are used)")
        all_efforts = len(self.effort_cols) == len(kinds["effort"])
        refs = None
        if not angles or not (all_efforts or "alpha_Nm" in m.columns):
            refs = tabulated(problem, t)
        self.theta = np.column_stack([m.columns[c] for c in angles]) if angles else refs.theta_ref
        self.angles_measured = bool(angles)
        if all_efforts:  # the preload the mechanism carries: the efforts' part along tau_n (the rest is orthogonal)
            tau = np.column_stack([m.columns[c] for c in kinds["effort"]])
            alpha = np.einsum("kmn,kn->km", np.linalg.pinv(fam.tau_n), tau - fam.tau_p)
            self.preload = "measured efforts"
        elif "alpha_Nm" in m.columns:
            alpha, self.preload = m.columns["alpha_Nm"][:, None], "alpha_Nm"
        else:
            alpha, self.preload = refs.alpha.reshape(len(t), -1), "controller"
        r = fam.r_p + np.einsum("kjcm,km->kjc", fam.r_n, alpha)
        N, nj = r.shape[:2]
        self.r = r.transpose(2, 0, 1).reshape(2, N * nj)
        idx = [kinds["effort"].index(c) for c in self.effort_cols]
        self.effort_index = idx
        self.tau_p = fam.tau_p[:, idx]
        self.tau_n = fam.tau_n[:, idx, :]
        f = seated_model(problem, params)
        self.f = f.map(N)
        self.f_value = problem.memo(("identify_seated_value", _layout(params)), lambda: ca.Function(
            "seated_value", f.sx_in(), f.call(f.sx_in())[:2], f.name_in(), f.name_out()[:2])).map(N)
        if problem.closed_form:
            self.args, self.pose_nominal, self.slip = (self.pose_ref.T, self.pose_d.T, self.theta.T, self.r), \
                self.pose_ref, None
        else:
            self.args, self.pose_nominal, self.slip = _graph_inputs(problem, q, self.pose_d, self.theta, self.r)

    def predict(self, p: np.ndarray, efforts: str = "measured", jacobian: bool = True):
        """(pose (N, 3), tau_friction (N, n_e), dpose (N, 3, np), dtau (N, n_e, np)) at parameters p,
        for the measured efforts (n_e of them) or with efforts='all' every actuator's; without
        `jacobian` dpose and dtau are None (a cheaper Function: trial steps, profiles)."""
        N, npar = len(self.m), len(self.params)
        idx = slice(None) if efforts == "all" else self.effort_index
        if not jacobian:
            pose, tau = (np.array(v) for v in self.f_value(*self.args, np.asarray(p, float)))
            tau = first_order_lag(self.m.t, tau.T, self.lag) if self.lag > 0 else tau.T
            return pose.T, tau[:, idx], None, None
        pose, tau, dpose, dtau = (np.array(v) for v in self.f(*self.args, np.asarray(p, float)))
        tau, dtau = tau.T, dtau.reshape(-1, N, npar).transpose(1, 0, 2)
        if self.lag > 0:
            tau, dtau = first_order_lag(self.m.t, tau, self.lag), first_order_lag(self.m.t, dtau, self.lag)
        return pose.T, tau[:, idx], dpose.reshape(3, N, npar).transpose(1, 0, 2), dtau[:, idx, :]

    def columns(self) -> list[str]:
        """The fitted columns: the measured pose columns, then the measured efforts."""
        return self.pose_cols + self.effort_cols

    def residuals(self, p: np.ndarray, sigma: dict, jacobian: bool = True) -> dict:
        """Whitened residuals at parameters p with the noise levels sigma {column: std}:
        {'r': (M,), 'J': (M, np) in p, 'raw': {column: (N,) residual in its unit},
        'expected': {column: (N,) fraction of the noise variance left after the projection},
        'prediction': {column: (N,) model}, 'explained': {column: (N,) what the parameters
        explain: the pose's offset from the path, the friction efforts off the preload}}."""
        kinds = measurement_columns(self.problem)
        pose, tau_f, dpose, dtau = self.predict(p, jacobian=jacobian)
        rs, js, raw, expected, pred, explained = [], [], {}, {}, {}, {}
        for c in self.pose_cols:
            i = kinds["pose"].index(c)
            s = sigma[c]
            raw[c] = self.m.columns[c] - pose[:, i]
            if c == "theta_rad":
                raw[c] = np.arctan2(np.sin(raw[c]), np.cos(raw[c]))
            expected[c], pred[c] = np.ones(len(raw[c])), pose[:, i]
            explained[c] = pose[:, i] - self.pose_nominal[:, i]
            rs.append(raw[c] / s)
            if jacobian:
                js.append(-dpose[:, i, :] / s)
        if self.effort_cols:
            s = np.array([sigma[c] for c in self.effort_cols])
            meas = np.column_stack([self.m.columns[c] for c in self.effort_cols])
            z = (meas - self.tau_p - tau_f) / s
            Q = np.linalg.qr(self.tau_n / s[None, :, None])[0]  # (N, ne, m): the whitened preload directions
            z = z - np.einsum("kim,kjm,kj->ki", Q, Q, z)
            zf = tau_f / s - np.einsum("kim,kjm,kj->ki", Q, Q, tau_f / s)  # the friction efforts off the preload
            if jacobian:
                dz = -dtau / s[None, :, None]
                dz = dz - np.einsum("kim,kjm,kjp->kip", Q, Q, dz)
            left = 1.0 - np.einsum("kim,kim->ki", Q, Q)
            for i, c in enumerate(self.effort_cols):
                raw[c], expected[c], explained[c] = z[:, i] * s[i], left[:, i], zf[:, i] * s[i]
                pred[c] = meas[:, i] - raw[c]
                rs.append(z[:, i])
                if jacobian:
                    js.append(dz[:, i, :])
        return {"r": np.concatenate(rs), "J": np.vstack(js) if jacobian else None, "raw": raw, "expected": expected,
                "prediction": pred, "explained": explained}

    def initial_noise(self) -> dict:
        """A first guess of the noise levels, for the weights of the first fit: 1 um, 1e-5 rad,
        1 % of an effort's RMS."""
        out = {}
        for c in self.columns():
            out[c] = 1e-5 if c == "theta_rad" else 1e-6 if c in ("x_m", "y_m") else \
                max(0.01 * float(np.sqrt(np.mean(self.m.columns[c] ** 2))), 1e-9)
        return out


def _graph_inputs(problem: Problem, q: np.ndarray, pose_d: np.ndarray, theta: np.ndarray, r: np.ndarray):
    """A graph's per-instant inputs of :func:`_build_graph` (the mapped Function's argument
    layout), its task pose at the ideal coordinates q (N, nq), and the slip velocities (N, nj)."""
    mech, model = problem.mechanism, problem.model
    N, k = len(q), mech.n_task
    qd = mech.motion(q, pose_d[:, :k], np.zeros((N, k)))[0]
    W = slip_rows(problem)
    slip = qd @ W.T
    Jf, _, _, S = (np.array(v).reshape(v.shape[0], N, v.shape[1] // N).transpose(1, 0, 2)
                   for v in mech.constraint_jacobian_function.map(N)(q.T, np.zeros((mech.nq, N))))
    ainv = np.linalg.inv(Jf)
    V = ainv[:, :, -k:]
    J = S @ V  # d theta = J d task
    G = np.linalg.pinv(J)
    P = J @ np.linalg.solve(np.swapaxes(J, 1, 2) @ J, np.swapaxes(W @ V, 1, 2))

    def pack(a):  # (N, rows, cols) -> (rows, N * cols): a mapped Function's matrix input
        return a.transpose(1, 0, 2).reshape(a.shape[1], -1)
    qs = ca.SX.sym("q", mech.nq)
    pose = np.array(ca.Function("task", [qs], [model.task_pose(qs)]).map(N)(q.T)).T
    return (q.T, pack(ainv), pack(G), slip.T, pack(P), theta.T, r), pose, slip


def noise_from_residuals(res: dict, n_par: int) -> dict:
    """Each column's noise level from its residuals: sum r^2 / sum (what the projection
    leaves), with the parameters' degrees of freedom shared out over all residuals."""
    M = sum(float(np.sum(v)) for v in res["expected"].values())
    dof = M / max(M - n_par, 1)
    return {c: float(np.sqrt(dof * np.sum(v ** 2) / max(np.sum(res["expected"][c]), 1e-300)))
            for c, v in res["raw"].items()}


def seated_measurements(problem: Problem, params: list[Parameter], values, t, noise: dict | None = None,
                        rng: np.random.Generator | None = None, effort_lag="controller") -> Measurements:
    """What the seated model predicts a mechanism with the parameters `values` (the nominal
    problem's otherwise) shows at the times t (N,) [s]: its task pose with the actuators at
    the controller's references, its actuator angles, its efforts (the controller's preload
    plus the seated journals' friction moments) and the preload alpha_Nm; with Gaussian
    noise {column: std} from rng. A synthetic truth for tests and benchmarks."""
    t = np.asarray(t, float)
    kinds = measurement_columns(problem)
    refs = tabulated(problem, t)
    cols = {c: refs.theta_ref[:, i] for i, c in enumerate(kinds["angle"])}
    cols["alpha_Nm"] = refs.alpha.reshape(len(t), -1)[:, 0]
    m = Measurements(t, {**cols, **{c: np.zeros(len(t)) for c in kinds["pose"]}})  # the preload: alpha_Nm
    data = SeatedData(problem, m, params, effort_lag)
    pose, tau_f, _, _ = data.predict(np.asarray(values, float), efforts="all")
    fam = problem.effort_family(data.pose_ref, data.pose_d, path_rows(problem.path, t)[:, 6:9])
    tau = fam.tau_p + np.einsum("knm,km->kn", fam.tau_n, refs.alpha.reshape(len(t), -1)) + tau_f
    cols.update({c: pose[:, i] for i, c in enumerate(kinds["pose"])})
    cols.update({c: tau[:, i] for i, c in enumerate(kinds["effort"])})
    rng = rng or np.random.default_rng(0)
    for c, s in (noise or {}).items():
        cols[c] = cols[c] + s * rng.standard_normal(len(t))
    return Measurements(t, cols, {}, f"seated model of {problem.name}")


def check_friction_explained(data: SeatedData, res: dict, key: str) -> tuple[float, float]:
    """(ratio, sliding): the ratio of the friction efforts the seated model explains to the
    systematic part of what it leaves in the measured efforts (RMS over every effort column;
    the systematic part is the residuals' lag-1 autocovariance, less three times its scatter
    under white noise), and the fraction of the instants at which some clearance journal
    slides faster than ``effects.friction.v1`` along the path. The seat model's friction is
    that of journals sliding steadily in their seats: where they still stick or settle (a
    start-up record), it explains little of the efforts, and a friction coefficient fitted to
    them is wrong however tight its interval. MeasurementError naming `key` (the friction
    coefficient) when the ratio is below :data:`FRICTION_EXPLAINED_MIN` and the journals slide
    at fewer than :data:`SLIDING_MIN` of the instants (a mechanism without friction that
    slides explains nothing and is right: its coefficient comes out near 0)."""
    if not data.effort_cols:
        return float("inf"), 1.0
    explained = np.concatenate([res["explained"][c] for c in data.effort_cols])
    left = [res["raw"][c] for c in data.effort_cols]
    # the residual's lag-1 autocovariance: its smooth (systematic) part's variance; white noise adds
    # nothing to it but a scatter of its variance / sqrt(samples), of which three are allowed
    lag1 = float(np.mean(np.concatenate([v[1:] * v[:-1] for v in left])))
    white = float(np.mean(np.concatenate([np.diff(v) for v in left]) ** 2)) / 2.0
    systematic = np.sqrt(max(lag1 - 3.0 * white / np.sqrt(sum(v.size - 1 for v in left)), 0.0))
    ratio = float(np.sqrt(np.mean(explained ** 2)) / systematic) if systematic > 0 else float("inf")
    if data.slip is None:
        pose, pose_d = ca.SX.sym("pose", 3), ca.SX.sym("pose_d", 3)
        f = ca.Function("slip", [pose, pose_d], [nrrr_slip(data.problem, pose, pose_d)]).map(len(data.m))
        slip = np.array(f(data.pose_ref.T, data.pose_d.T)).T
    else:
        slip = data.slip
    v1 = data.problem.scene.effects.friction.v1
    sliding = float(np.mean(np.max(np.abs(slip), axis=1) > v1))
    if not ratio >= FRICTION_EXPLAINED_MIN and sliding < SLIDING_MIN:
        raise MeasurementError(
            f"{key}: the seated model does not explain these efforts (its friction efforts, RMS "
            f"{np.sqrt(np.mean(explained ** 2)):.3g}, are {ratio:.2g} times the systematic effort residual it leaves, "
            f"RMS {systematic:.3g}; at least {FRICTION_EXPLAINED_MIN:g} is required) and its journals are not sliding "
            f"steadily in their seats over {data.m.t[0]:.4g} to {data.m.t[-1]:.4g} s (faster than effects.friction.v1 "
            f"= {v1:g} m/s at {100 * sliding:.0f} % of the instants, at least {100 * SLIDING_MIN:.0f} % required: a "
            "start-up?); no estimate is returned. Fit a longer record, or leave the friction coefficient out of the "
            "parameters")
    return ratio, sliding

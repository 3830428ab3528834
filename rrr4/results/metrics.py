"""Metrics of a simulation (one :class:`rrr4.Simulation`): one implementation for the study
(:func:`arm_metrics`, :func:`driven_metrics`), the sweep's CSV columns and the robustness
table (:func:`scalar_metrics`).

Contact state per output sample: a clearance joint is in contact while its penetration
delta > 0 (Flores). With one output sample per integrator step (as the study runs) this is
the state the simulation's own contact-loss counter sees, so loss events can be located in
time. Ideal joints never lose contact; their "contact force" is the pin reaction.

Peaks and minima of the contact forces, the penetration and the efforts are those of the
motion, not of its samples: the simulation tracks them at every integrator step
(``Simulation.extremes``), so a sweep that keeps outputs at 1 kHz and a run that keeps every
step report the same numbers. Ideal joints' reactions and the prescribed mode's efforts are
taken over the output samples.

The start-up window. A seated start puts the platform on the path at t = 0 and its offset
builds over 0.1 to 0.5 s, so a short run's averages mix the transient into the steady
behaviour. ``skip`` [s] (``rrr4 run --skip``, a sweep spec's ``skip:``) discards the samples
before it from the metrics over the output samples (:data:`WINDOWED`); the metrics tracked
at every integrator step or counted by the simulation itself (:data:`WHOLE_RUN`) cannot be
cut after the fact and stay over the whole run. :func:`settling_time` says when the platform
error has reached its steady behaviour, i.e. how much to skip.
"""

from __future__ import annotations

import numpy as np

from ..checks import argument
from ..errors import SceneError
from ..problem import Problem
from ..simulation import Simulation

__all__ = ["scalar_metrics", "SCALAR_METRICS", "arm_metrics", "loss_times", "contact_onsets", "driven_metrics",
           "driven_window", "driven_scalar_metrics", "DRIVEN_SCALAR_METRICS",
           "settling_time", "check_skip", "window", "WINDOWED", "WHOLE_RUN", "SETTLING_TAIL", "SETTLING_MARGIN"]

SCALAR_METRICS = ("contact_loss_events", "platform_error_rms_m", "platform_error_max_m", "min_contact_force_N",
                  "peak_contact_force_N", "torque_rms_Nm")
# the flat metrics of a driven scene's arm (no task body): :func:`driven_scalar_metrics`
DRIVEN_SCALAR_METRICS = ("contact_loss_events", "impacts_per_revolution", "acceleration_deviation_rms_m_s2",
                         "acceleration_deviation_max_m_s2", "driver_effort_peak_Nm", "driver_effort_rms_Nm",
                         "driver_effort_peak_N", "driver_effort_rms_N", "max_penetration_m", "peak_contact_force_N")
# metrics over the output samples at t >= skip, and those over the whole run whatever the skip
WINDOWED = ("platform_error_rms_m", "platform_error_max_m", "torque_rms_Nm", "free_flight_fraction",
            "effort_at_limit_fraction", "peak_contact_force_N (ideal joints)", "min_contact_force_N (ideal joints)",
            "driver and acceleration metrics of a driven scene")
WHOLE_RUN = ("contact_loss_events", "last_contact_loss_s", "peak_contact_force_N (clearance joints)",
             "min_contact_force_N (clearance joints)", "max_penetration_m", "torque_peak_Nm", "energy_audit_residual",
             "converged", "settling_time_s")
SETTLING_TAIL = 0.25    # the last quarter of the run is the platform error's steady behaviour
SETTLING_MARGIN = 0.1   # the band: that quarter's range, widened by 10 % of its largest error on each side


def check_skip(skip, t_end: float, key: str = "skip") -> float:
    """`skip` [s] as a float, 0 <= skip < t_end [s], or a one-line SceneError naming `key`."""
    s = argument(key, skip, allow_zero=True)
    if s >= t_end:
        raise SceneError(f"{key}: {s:g} s is not allowed (the start-up window to discard must be shorter than the "
                         f"run: 0 <= {key} < t_end = {t_end:g} s)")
    return s


def window(sim: Simulation, skip: float = 0.0) -> np.ndarray:
    """(N,) bool: the output samples at t >= skip [s] (all of them with skip = 0)."""
    return sim.t >= sim.t[0] + skip - 1e-12 * max(1.0, abs(skip))


def settling_time(t: np.ndarray, e: np.ndarray) -> float:
    """When the platform error e (N,) [m] at the times t (N,) [s] has settled [s].

    Its steady behaviour is the band [lo - m, hi + m]: lo, hi the smallest and largest error
    over the last :data:`SETTLING_TAIL` of the run, m = :data:`SETTLING_MARGIN` * hi. The
    settling time is the first output instant from which on the error stays inside that band
    (t[0] when it never leaves it). By construction it is at most the start of that last
    quarter; a value near it means the run is too short to have settled."""
    t, e = np.asarray(t, float), np.asarray(e, float)
    tail = t >= t[0] + (1 - SETTLING_TAIL) * (t[-1] - t[0])
    lo, hi = float(e[tail].min()), float(e[tail].max())
    m = SETTLING_MARGIN * hi
    out = (e < lo - m) | (e > hi + m)
    if not out.any():
        return float(t[0])
    last = int(np.flatnonzero(out)[-1])
    return float(t[min(last + 1, len(t) - 1)])


def loss_times(sim: Simulation) -> dict:
    """joint -> (k,) times [s] of contact -> free-flight transitions (empty for ideal joints)."""
    out = {j.name: np.zeros(0) for j in sim.scene.joints}
    contact = sim.penetration > 0
    for k, name in enumerate(sim.clearance_joints):
        lost = contact[:-1, k] & ~contact[1:, k]
        out[name] = sim.t[1:][lost]
    return out


def scalar_metrics(sim: Simulation, skip: float = 0.0) -> dict:
    """One number per metric of :data:`SCALAR_METRICS` (units in the names):
    contact_loss_events (all joints, whole run, from the simulation's per-step counter);
    platform_error_rms_m / _max_m (position distance to the commanded path, over the
    samples at t >= skip [s]); min_contact_force_N / peak_contact_force_N (over every
    clearance joint and integrator step of the whole run; NaN without one); torque_rms_Nm
    (over the samples at t >= skip and the actuators; 0 without actuators)."""
    keep = window(sim, skip)
    e, ext, tau = sim.platform_error[keep], sim.extremes, sim.tau[keep]
    nc = len(sim.clearance_joints)
    return {"contact_loss_events": int(sum(sim.contact_loss_events.values())),
            "platform_error_rms_m": float(np.sqrt(np.mean(e**2))),
            "platform_error_max_m": float(np.max(e)),
            "min_contact_force_N": float(ext["normal_force_min"].min()) if nc else float("nan"),
            "peak_contact_force_N": float(ext["normal_force_max"].max()) if nc else float("nan"),
            "torque_rms_Nm": float(np.sqrt(np.mean(tau**2))) if tau.size else 0.0}


def arm_metrics(sim: Simulation, wall_time: float, skip: float = 0.0, compile_time: float = 0.0) -> dict:
    """JSON-ready metrics of one simulation (units in the key names); those of
    :data:`WINDOWED` over the output samples at t >= skip [s], the rest over the whole run.

    contact_loss_events: joint -> count from the simulation's per-step counter (whole run);
    last_contact_loss_s (None without losses);
    free_flight_fraction: joint -> share of samples with delta <= 0; max_penetration_m;
    peak_contact_force_N / min_contact_force_N: joint -> max / min normal force over every
    integrator step (ideal joint: |reaction|, over the samples); platform_error_rms_m /
    _max_m (position distance to the commanded path); torque_rms_Nm (over time and
    actuators), torque_peak_Nm (over every step in torque mode);
    settling_time_s (with a task body: :func:`settling_time` of the platform error, whole run);
    energy_audit_residual; converged (the energy audit's verdict, :mod:`rrr4.simulation.verdict`)
    with energy_audit_tolerance, energy_imbalance_J and energy_exchanged_J behind it;
    wall_time_s (building and stepping, without compiling C); stepping (:func:`stepping_text`);
    compile_time_s (the C compiler's time for this simulation, 0 when its libraries were in
    the cache); simulated_time_s; integrator, step_s, steps.
    A metric that does not apply is absent: the contact metrics list the clearance and the
    passive ideal revolute joints (a prismatic joint has no journal), the platform error needs
    a task body, the torques actuators.
    """
    model = Problem.from_scene(sim.scene).model
    idx = {j: k for k, j in enumerate(sim.clearance_joints)}
    ideal = {j: k for k, j in enumerate(sim.ideal_passive_joints)}
    names = [j.name for j in sim.scene.joints if j.name in idx or j.name in ideal]
    times = loss_times(sim)

    def per_joint(clearance_value, ideal_value):
        return {j: (clearance_value(idx[j]) if j in idx else ideal_value(ideal[j])) for j in names}

    keep = window(sim, skip)
    reaction = np.linalg.norm(sim.reaction, axis=2)[keep] if sim.reaction.size else np.zeros((keep.sum(), 0))
    flat, ext = scalar_metrics(sim, skip), sim.extremes
    tau_peak = ext["tau_abs_max"] if "tau_abs_max" in ext else np.abs(sim.tau)
    task = ({**{k: flat[k] for k in ("platform_error_rms_m", "platform_error_max_m")},
             "settling_time_s": settling_time(sim.t, sim.platform_error)} if model.task is not None else {})
    efforts = ({"torque_rms_Nm": flat["torque_rms_Nm"], "torque_peak_Nm": float(np.max(tau_peak, initial=0.0)),
                **_at_limit(sim, keep)} if model.n_actuators else {})
    return {
        "contact_loss_events": {j: int(sim.contact_loss_events.get(j, 0)) for j in names},
        "last_contact_loss_s": max((float(v[-1]) for v in times.values() if v.size), default=None),
        "free_flight_fraction": per_joint(lambda k: float(np.mean(sim.penetration[keep, k] <= 0)), lambda k: 0.0),
        "max_penetration_m": float(np.max(ext["penetration_max"], initial=0.0)),
        "peak_contact_force_N": per_joint(lambda k: float(ext["normal_force_max"][k]),
                                          lambda k: float(np.max(reaction[:, k]))),
        "min_contact_force_N": per_joint(lambda k: float(ext["normal_force_min"][k]),
                                         lambda k: float(np.min(reaction[:, k]))),
        **task,
        **efforts,
        "energy_audit_residual": float(sim.energy_audit_residual),
        **_verdict(sim),
        "wall_time_s": float(wall_time),
        "compile_time_s": float(compile_time),
        "stepping": stepping_text(sim),
        "simulated_time_s": float(sim.t[-1] - sim.t[0]),
        "integrator": sim.stats["method"],
        "step_s": float(sim.stats["step"]),
        "steps": int(sim.stats["steps"]),
    }


def stepping_text(sim: Simulation) -> str:
    """How a run stepped: 'compiled C', 'virtual machine', or 'virtual machine, compiled C from
    t = ... s' (the compile policy of :func:`rrr4.simulation.default_jit`; the same states),
    and what the policy decided, with its estimates, where it decided."""
    s = sim.stats.get("stepping") or {}
    why = f"; {s['decision']}" if s.get("decision") else ""  # the compile policy's decision and estimates
    if not s.get("compiled"):
        return "virtual machine" + why
    t = s.get("compiled_from_s")
    return ("compiled C" if t is None else f"virtual machine, compiled C from t = {t:.4g} s") + why


def _verdict(sim: Simulation) -> dict:
    """converged and the numbers behind it: the residual's tolerance, the largest energy
    imbalance [J] and the energy the run exchanges [J] (:attr:`Simulation.verdict`)."""
    v = sim.verdict
    return {"converged": v.converged, "energy_audit_tolerance": v.tolerance, "energy_imbalance_J": v.imbalance_J,
            "energy_exchanged_J": v.energy_exchanged_J}


def _at_limit(sim: Simulation, keep: np.ndarray) -> dict:
    """effort_at_limit_fraction: actuator -> share of the output samples `keep` where the
    controller's effort sits at its limit (clipped), for a torque-driven simulation with actuators."""
    model = Problem.from_scene(sim.scene).model
    if sim.scene.actuation.mode != "torque":
        return {}
    limits = np.asarray(sim.scene.torque_limit, float)
    at = np.abs(sim.tau[keep]) >= limits * (1 - 1e-9)
    return {"effort_at_limit_fraction": {a: float(np.mean(at[:, i])) for i, a in enumerate(model.actuator_names)}}


def contact_onsets(sim: Simulation) -> dict:
    """clearance joint -> (k,) times [s] of free-flight -> contact transitions (impacts)."""
    contact = sim.penetration > 0
    return {j: sim.t[1:][~contact[:-1, k] & contact[1:, k]] for k, j in enumerate(sim.clearance_joints)}


def driven_metrics(sim: Simulation, ideal: Simulation, t_from: float, revolution: float) -> dict:
    """Metrics of a driven mechanism against its ideal twin (same driver), over t >= t_from
    (after the start transient). revolution [s]: period of the first driver.

    impacts_per_revolution: joint -> contact onsets per driver revolution;
    body_acceleration_peak_m_s2: body -> max |a| of the centre of mass;
    acceleration_deviation_rms_m_s2 / _max_: body -> RMS / max |a - a_ideal|;
    driver_effort_peak_Nm / _rms_Nm: revolute driver -> max / RMS |effort| [N m], and
    driver_effort_peak_N / _rms_N for prismatic drivers [N] (each only where such drivers exist)."""
    model = Problem.from_scene(sim.scene).model
    keep = sim.t >= t_from
    span = max(float(sim.t[keep][-1] - sim.t[keep][0]), 1e-300) if keep.sum() > 1 else 1e-300
    onsets = contact_onsets(sim)
    acc = {b: sim.qdd[:, model.coordinates(b)][:, :2] for b in model.body_names}
    acc_ideal = {b: ideal.qdd[:, model.coordinates(b)][:, :2] for b in model.body_names}
    dev = {b: np.linalg.norm(acc[b] - acc_ideal[b], axis=1)[keep] for b in model.body_names}
    efforts: dict = {}
    for k, d in enumerate(sim.scene.graph.drivers):
        unit = "Nm" if sim.scene.graph.joint(d.joint).type == "revolute" else "N"
        e = sim.driver_effort[keep, k]
        efforts.setdefault(f"driver_effort_peak_{unit}", {})[d.name] = float(np.max(np.abs(e)))
        efforts.setdefault(f"driver_effort_rms_{unit}", {})[d.name] = float(np.sqrt(np.mean(e**2)))
    return {
        "after_s": float(t_from),
        "impacts_per_revolution": {j: float(np.sum(v >= t_from) * revolution / span) for j, v in onsets.items()},
        "body_acceleration_peak_m_s2": {b: float(np.max(np.linalg.norm(a[keep], axis=1))) for b, a in acc.items()},
        "acceleration_deviation_rms_m_s2": {b: float(np.sqrt(np.mean(v**2))) for b, v in dev.items()},
        "acceleration_deviation_max_m_s2": {b: float(np.max(v)) for b, v in dev.items()},
        **efforts,
    }


def driven_window(scene, t_end: float, skip: float = 0.0) -> tuple[float, float]:
    """(t_from, revolution) [s] of a driven scene's metrics over a run of t_end [s]:
    revolution is the first driver's period (t_end without a turning driver); the metrics
    start after `skip` when one is given, else after the first revolution (the start
    transient from centred journals) when it takes less than 3/4 of the run, else at 0."""
    speed = abs(scene.graph.drivers[0].speed) if scene.graph.drivers else 0.0
    revolution = 2 * np.pi / speed if speed > 0 else float(t_end)
    t_from = skip if skip > 0 else revolution if revolution < 0.75 * t_end else 0.0
    return float(t_from), float(revolution)


def driven_scalar_metrics(sim: Simulation, ideal: Simulation | None, t_from: float, revolution: float) -> dict:
    """The metrics of :data:`DRIVEN_SCALAR_METRICS` that apply to a driven simulation, one
    number each (units in the names), from :func:`driven_metrics` (t >= t_from [s]) and the
    extremes tracked at every integrator step. With clearance joints: contact_loss_events and
    impacts_per_revolution (summed over them), max_penetration_m and peak_contact_force_N
    (over them and every step of the whole run). Against the ideal twin `ideal` (None: the
    simulation is the twin itself, and the deviation does not apply):
    acceleration_deviation_rms_m_s2 / _max_m_s2 (the largest body's). Per driver unit that
    the scene has: driver_effort_peak_Nm / _rms_Nm (revolute) and driver_effort_peak_N /
    _rms_N (prismatic), the largest driver's. A metric that does not apply is absent."""
    m = driven_metrics(sim, sim if ideal is None else ideal, t_from, revolution)
    out: dict = {}
    if sim.clearance_joints:
        ext = sim.extremes
        out.update(contact_loss_events=int(sum(sim.contact_loss_events.values())),
                   impacts_per_revolution=float(sum(m["impacts_per_revolution"].values())),
                   max_penetration_m=float(np.max(ext["penetration_max"])),
                   peak_contact_force_N=float(np.max(ext["normal_force_max"])))
    if ideal is not None and m["acceleration_deviation_rms_m_s2"]:
        out["acceleration_deviation_rms_m_s2"] = max(m["acceleration_deviation_rms_m_s2"].values())
        out["acceleration_deviation_max_m_s2"] = max(m["acceleration_deviation_max_m_s2"].values())
    for k in DRIVEN_SCALAR_METRICS:
        if k.startswith("driver_effort_") and k in m:
            out[k] = max(m[k].values())
    return {k: out[k] for k in DRIVEN_SCALAR_METRICS if k in out}

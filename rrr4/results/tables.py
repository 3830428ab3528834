"""Tables of a study: the time-series CSV and the `report.md` table."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ..contact.lubrication import min_film_thickness
from .study import PRELOAD_ARMS, Study
from .summary import contact_lines, film_joints, unconverged, verdict_line

__all__ = ["write_timeseries_csv", "report_markdown"]


def write_timeseries_csv(study: Study, path: Path, rate: float | None = None) -> Path:
    """Time series at `rate` [Hz] (default the path's sample rate), one row per instant.

    Columns: t_s, x_ref_m, y_ref_m, theta_ref_rad, alpha_Nm (preload, if any), then per arm
    (prefix ``<arm>_``, e.g. ``with_preload_``): x_m, y_m, theta_rad, error_m,
    tau_<actuator>_Nm (or _N for a prismatic actuator), theta_<actuator>_rad (its coordinate;
    _m for a prismatic one), per clearance joint Fn_<J>_N (normal force), Ft_<J>_N (friction
    force on the journal along the tangent, the contact normal e/|e| rotated by +90 deg; 0
    without friction), penetration_<J>_m, ex_<J>_m, ey_<J>_m, and per ideal passive revolute
    joint Rx_<J>_N, Ry_<J>_N (its reaction, the force of the joint's first body on its second,
    global frame).
    A driven scene (no task; arms ``with_clearance_`` / ``ideal_``) has instead, per body B,
    B_x_m, B_y_m, B_theta_rad, B_ax_m_s2, B_ay_m_s2 and per driver D, D_effort_Nm (or _N on a
    prismatic joint).
    """
    problem = study.problem
    model = problem.model
    base = next(iter(study.arms.values())).simulation
    driven = model.task is None
    rate = study.scene.path.sample_rate if rate is None else rate
    every = max(int(round(1.0 / (rate * (base.t[1] - base.t[0])))), 1)
    rows = np.arange(0, len(base.t), every)
    t = base.t[rows]
    cols = {"t_s": t} if driven else {"t_s": t, "x_ref_m": base.pose_ref[rows, 0], "y_ref_m": base.pose_ref[rows, 1],
                                      "theta_ref_rad": base.pose_ref[rows, 2]}
    if study.preload is not None and np.ndim(study.preload.alpha) == 1:
        cols["alpha_Nm"] = np.interp(t, study.preload.t, study.preload.alpha)
    for name, arm in study.arms.items():
        sim = arm.simulation
        if driven:
            for b in model.body_names:
                q, qdd = sim.q[rows][:, model.coordinates(b)], sim.qdd[rows][:, model.coordinates(b)]
                for k, key in enumerate(("x_m", "y_m", "theta_rad")):
                    cols[f"{name}_{b}_{key}"] = q[:, k]
                cols[f"{name}_{b}_ax_m_s2"], cols[f"{name}_{b}_ay_m_s2"] = qdd[:, 0], qdd[:, 1]
            for k, d in enumerate(study.scene.graph.drivers):
                cols[f"{name}_{d.name}_effort_{_unit(problem, d.joint)}"] = sim.driver_effort[rows, k]
        else:
            for k, key in enumerate(("x_m", "y_m", "theta_rad")):
                cols[f"{name}_{key}"] = sim.pose[rows, k]
            cols[f"{name}_error_m"] = sim.platform_error[rows]
        theta = np.array(model.actuator_coordinates_function.map(len(rows))(sim.q[rows].T)[0]).T
        for i, a in enumerate(model.actuator_names):
            cols[f"{name}_tau_{a}_{_unit(problem, model.actuated_joints[i])}"] = sim.tau[rows, i]
        for i, a in enumerate(model.actuator_names):
            revolute = problem.joint(model.actuated_joints[i]).type == "revolute"
            cols[f"{name}_theta_{a}_{'rad' if revolute else 'm'}"] = theta[:, i]
        for k, j in enumerate(sim.clearance_joints):
            cols[f"{name}_Fn_{j}_N"] = sim.normal_force[rows, k]
            cols[f"{name}_Ft_{j}_N"] = sim.friction_force[rows, k]
            cols[f"{name}_penetration_{j}_m"] = sim.penetration[rows, k]
            cols[f"{name}_ex_{j}_m"] = sim.eccentricity[rows, k, 0]
            cols[f"{name}_ey_{j}_m"] = sim.eccentricity[rows, k, 1]
        for k, j in film_joints(problem, sim):  # the oil film's share of the force, and its thinnest gap
            cols[f"{name}_film_Fx_{j}_N"] = sim.film_force[rows, k, 0]
            cols[f"{name}_film_Fy_{j}_N"] = sim.film_force[rows, k, 1]
            cols[f"{name}_h_min_{j}_m"] = min_film_thickness(sim.eccentricity[rows, k],
                                                             problem.joint(j).radial_clearance)
        for k, j in enumerate(sim.ideal_passive_joints):
            cols[f"{name}_Rx_{j}_N"] = sim.reaction[rows, k, 0]
            cols[f"{name}_Ry_{j}_N"] = sim.reaction[rows, k, 1]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        w.writerows(np.column_stack(list(cols.values())).tolist())
    return path


def _unit(problem, joint: str) -> str:
    """The unit of an effort on `joint` in a key: Nm on a revolute joint, N on a prismatic one."""
    return "Nm" if problem.joint(joint).type == "revolute" else "N"


def _fmt(v, scale=1.0, digits=4):
    return "-" if v is None else f"{v * scale:.{digits}g}"


def report_markdown(summary: dict) -> str:
    """A short Markdown report: one table comparing the arms, the preload and the targets."""
    if summary.get("ideal") is not None:
        return _driven_report(summary)
    arms = [(k, summary[k]) for k in PRELOAD_ARMS if summary.get(k) is not None]
    head = "| metric | " + " | ".join(k.replace("_", " ") for k, _ in arms) + " |"
    rows = [head, "|---" * (len(arms) + 1) + "|"]

    def row(label, f):
        rows.append(f"| {label} | " + " | ".join(f(m) for _, m in arms) + " |")

    row("contact-loss events (all joints, whole run)", lambda m: str(sum(m["contact_loss_events"].values())))
    row("largest free-flight fraction", lambda m: _fmt(max(m["free_flight_fraction"].values(), default=0.0)))
    row("max penetration [um]", lambda m: _fmt(m["max_penetration_m"], 1e6))
    row("peak contact force [N]", lambda m: _fmt(max(m["peak_contact_force_N"].values(), default=0.0)))
    _film_rows(row, arms)
    row("smallest contact force [N]", lambda m: _fmt(min(m["min_contact_force_N"].values(), default=None)))
    row("platform error RMS [um]", lambda m: _fmt(m["platform_error_rms_m"], 1e6))
    row("platform error max [um]", lambda m: _fmt(m["platform_error_max_m"], 1e6))
    row("platform error settling time [s]", lambda m: _fmt(m.get("settling_time_s")))
    row("effort RMS [N m; N at a prismatic actuator]", lambda m: _fmt(m["torque_rms_Nm"]))
    row("largest share of time at an effort limit", lambda m: _fmt(max(m.get("effort_at_limit_fraction", {}).values(),
                                                                       default=None)))
    row("energy audit residual", lambda m: _fmt(m["energy_audit_residual"], 1.0, 3))
    row("verdict (energy audit)", _word)
    if any("step_refinement" in m for _, m in arms):
        row("steps tried until converged [s] (--converge)", _refined)
    row("simulated time [s]", lambda m: _fmt(m["simulated_time_s"]))
    row("integrator, step [s]", lambda m: f"{m['integrator']}, {m['step_s']:g}")
    row("wall time [s]", lambda m: _fmt(m["wall_time_s"], 1.0, 3))
    row("C compile time [s] (not in the wall time)", lambda m: _fmt(m.get("compile_time_s", 0.0), 1.0, 3))

    joints = list(arms[0][1]["contact_loss_events"])
    per = ["", "| joint | " + " | ".join(f"losses {k.replace('_', ' ')}" for k, _ in arms) + " |",
           "|---" * (len(arms) + 1) + "|"] if joints else []  # no table without a passive revolute joint
    for j in joints:
        per.append(f"| {j} | " + " | ".join(str(m["contact_loss_events"][j]) for _, m in arms) + " |")

    pre = summary["preload"]
    if pre.get("method"):
        pre_line = (f"Preload: method `{pre['method']}`, f_min = {pre['f_min_N']:g} N, feasible at "
                    f"{pre['samples'] - pre['infeasible_samples']}/{pre['samples']} path samples, alpha in "
                    f"[{pre['alpha_min_Nm']:.4g}, {pre['alpha_max_Nm']:.4g}] N m.")
        for e in pre.get("effort_over_limit") or ():
            pre_line += (f" **The preload cannot hold:** actuator {e['actuator']} needs {e['peak']:.4g} {e['unit']} at "
                         f"t = {e['t_peak_s']:.4g} s against its limit {e['limit']:g} {e['unit']} (over it at "
                         f"{e['samples']} samples).")
        if pre.get("effort_over_limit"):
            pre_line += f" In the simulations {pre['efforts_in_simulation']}."
    else:
        pre_line = f"No preload arm: {pre['reason']}."
    forces = [f"- force element `{e['name']}`: {e['type'].replace('_', ' ')} on {', '.join(e['bodies'])}; "
              + ", ".join(f"{k} = {v}" for k, v in e.items() if k not in ("name", "type", "bodies"))
              for e in summary.get("forces", ())]
    lines = [f"# Study of `{summary['scene']}`", "", summary["description"], "", pre_line, "", *_contact(summary),
             *_before(summary),
             *forces, *([""] if forces else []), *_window(summary), *rows, *per]
    tg = summary.get("targets") or {}
    if tg.get("not_claimed"):
        lines += ["", f"Targets: **not claimed** ({tg['not_claimed']})."]
    if "zero_losses_with_preload" in tg:
        lines += ["", "Targets: zero losses with preload over the whole run: "
                  f"**{'yes' if tg['zero_losses_with_preload'] else 'no'}**; RMS error with/without = "
                  f"{_fmt(tg['rms_error_ratio_with_to_without'], 1.0, 3)} (target <= 0.5: "
                  f"**{'yes' if tg['rms_error_at_most_half'] else 'no'}**)."]
    if "zero_losses_compensated" in tg:
        lines += ["", "With clearance compensation: zero losses "
                  f"**{'yes' if tg['zero_losses_compensated'] else 'no'}**, RMS error <= 1 um "
                  f"**{'yes' if tg['compensated_rms_at_most_1um'] else 'no'}**."]
    lines += _verdict(summary)
    journals = summary.get("initial_journals", "centred")
    lines += ["", f"Start: journals {journals}"
              + (" (each clearance journal rests on its bearing wall under the ideal reaction at t = 0; "
                 "with no load, as without preload at rest, it stays centred)." if journals == "seated" else ".")]
    return "\n".join(lines) + "\n"


def _refined(m: dict) -> str:
    """The steps an arm of `rrr4 run --converge` tried, with their residuals and total cost."""
    r = m.get("step_refinement")
    if r is None:
        return "-"
    tried = ", ".join(f"{h:g} ({'failed' if e is None else f'{e:.2g}'})"
                      for h, e in zip(r["steps_s"], r["energy_audit_residuals"], strict=True))
    return f"{tried}; {r['wall_time_s'] + r['compile_time_s']:.3g} s"


def _before(summary: dict) -> list[str]:
    """The warnings said before the run (a law outside its range, a step too coarse), then a blank line."""
    warn = summary.get("before_the_run") or []
    return [f"**Before the run:** {w}." for w in warn] + ([""] if warn else [])


def _word(m: dict) -> str:
    """An arm's verdict in the report's table (an arm of a summary from before the verdict: -)."""
    return "-" if "converged" not in m else "converged" if m["converged"] else "**not converged**"


def _verdict(summary: dict) -> list[str]:
    """The paragraph that says which arms have not converged and what would converge them;
    nothing when all have."""
    line = verdict_line(summary)
    if line is None:
        return []
    tol = next(iter(unconverged(summary).values()))["energy_audit_tolerance"]
    return ["", f"**{line[0].upper() + line[1:]}.** An arm has converged when its largest energy imbalance is at "
            f"most {tol:g} of the energy it exchanges and, for a driven scene's clearance arm, when its half-step "
            "rerun stays within 1 % of the smallest radial clearance over the first millisecond (docs/checks.md)."]


def _window(summary: dict) -> list[str]:
    """The start-up window the metrics discard, when one is set, then a blank line."""
    w = summary.get("metrics_window") or {}
    if not w.get("skip_s"):
        return []
    return [f"Metrics over the output samples ({', '.join(w['over_window'])}) are taken after the start-up window "
            f"t >= {w['skip_s']:g} s; the others ({', '.join(w['over_whole_run'])}) are over the whole run.", ""]


def _contact(summary: dict) -> list[str]:
    """The contact and friction numbers the simulations used, as a list, then a blank line."""
    return [f"- {line.strip()}" for line in contact_lines(summary.get("contact"))] + [""]


def _film_rows(row, arms: list) -> None:
    """The lubricated joints' rows: the film's peak force, the peak total (dry + film) force
    and the minimum film thickness h_min = c (1 - eps)."""
    def film(key, j, scale=1.0):
        return lambda m: _fmt(m["film"][j][key], scale) if "film" in m else "-"
    for j in next((a["film"] for _, a in arms if "film" in a), {}):
        row(f"peak film force at {j} [N]", film("peak_film_force_N", j))
        row(f"peak total force (dry + film) at {j} [N]", film("peak_total_force_N", j))
        row(f"min film thickness h_min = c (1 - eps) at {j} [um]", film("min_film_thickness_m", j, 1e6))


def _driven_report(summary: dict) -> str:
    """Report of a driven scene: clearance against the ideal twin, and the half-step rerun."""
    arms = [(k, summary[k]) for k in ("with_clearance", "half_step", "ideal") if summary.get(k) is not None]
    label = {"with_clearance": "with clearance", "half_step": "with clearance, half step", "ideal": "ideal joints"}
    rows = ["| metric | " + " | ".join(label[k] for k, _ in arms) + " |", "|---" * (len(arms) + 1) + "|"]

    def row(text, f):
        rows.append(f"| {text} | " + " | ".join(f(m) for _, m in arms) + " |")

    after = arms[0][1]["after_s"]
    row("integrator, step [s]", lambda m: f"{m['integrator']}, {m['step_s']:g}")
    row("contact-loss events (whole run)", lambda m: str(sum(m["contact_loss_events"].values())))
    for j in summary["clearance_joints"]:
        row(f"impacts per revolution at {j} (t >= {after:.4g} s)",
            lambda m, j=j: _fmt(m["impacts_per_revolution"].get(j)))
        row(f"peak contact force at {j} [N]", lambda m, j=j: _fmt(m["peak_contact_force_N"][j]))
    _film_rows(row, arms)
    row("max penetration [um]", lambda m: _fmt(m["max_penetration_m"], 1e6))
    for b in arms[0][1]["body_acceleration_peak_m_s2"]:
        row(f"peak acceleration of {b} [m/s^2]", lambda m, b=b: _fmt(m["body_acceleration_peak_m_s2"][b]))
        row(f"RMS acceleration deviation of {b} from ideal [m/s^2]",
            lambda m, b=b: _fmt(m["acceleration_deviation_rms_m_s2"][b]))
    for key, unit in (("driver_effort_peak_Nm", "N m"), ("driver_effort_peak_N", "N")):
        for d in arms[0][1].get(key, {}):
            row(f"peak effort of driver {d} [{unit}]", lambda m, d=d, key=key: _fmt(m[key][d]))
    row("energy audit residual", lambda m: _fmt(m["energy_audit_residual"], 1.0, 3))
    row("verdict (energy audit; clearance arm: and its half-step rerun)", _word)
    row("wall time [s]", lambda m: _fmt(m["wall_time_s"], 1.0, 3))
    diff = (summary.get("step_convergence") or {}).get("trajectory_difference_m", {})
    agree = ("Largest centre-of-mass distance between the runs at the two steps: "
             + ", ".join(f"{k.replace('_', ' ')} {v * 1e6:.3g} um" for k, v in diff.items()) + ".") if diff else ""
    lines = [f"# Study of `{summary['scene']}`", "", summary["description"], "",
             f"Driven mechanism: the clearance run against its ideal twin under the same driver; one driver "
             f"revolution takes {summary['revolution_s']:.4g} s, and rates and deviations are taken after "
             f"t = {after:.4g} s (the start transient). The half-step column repeats the clearance run at half "
             "the step: where it agrees, the number has converged in the step; impact-resolved quantities of a "
             "rattling joint (peak forces, the timing of single impacts) are sensitive to it.", "",
             *_contact(summary), *_before(summary), *rows, "", agree, *_verdict(summary)]
    return "\n".join(lines) + "\n"

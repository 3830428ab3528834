"""Tables of a study: the time-series CSV and the `report.md` table."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ..study import Study

__all__ = ["write_timeseries_csv", "report_markdown"]


def write_timeseries_csv(study: Study, path: Path, rate: float | None = None) -> Path:
    """Time series at `rate` [Hz] (default the path's sample rate), one row per instant.

    Columns: t_s, x_ref_m, y_ref_m, theta_ref_rad, alpha_Nm (preload, if any), then per arm
    (prefix ``with_preload_`` / ``without_preload_``): x_m, y_m, theta_rad, error_m,
    tau<i>_Nm, and per clearance joint Fn_<J>_N, penetration_<J>_m, ex_<J>_m, ey_<J>_m.
    """
    base = study.arms["without_preload"].simulation
    rate = study.scene.path.sample_rate if rate is None else rate
    every = max(int(round(1.0 / (rate * (base.t[1] - base.t[0])))), 1)
    rows = np.arange(0, len(base.t), every)
    t = base.t[rows]
    cols = {"t_s": t, "x_ref_m": base.pose_ref[rows, 0], "y_ref_m": base.pose_ref[rows, 1],
            "theta_ref_rad": base.pose_ref[rows, 2]}
    if study.preload is not None and np.ndim(study.preload.alpha) == 1:
        cols["alpha_Nm"] = np.interp(t, study.preload.t, study.preload.alpha)
    for name, arm in study.arms.items():
        sim = arm.simulation
        for k, key in enumerate(("x_m", "y_m", "theta_rad")):
            cols[f"{name}_{key}"] = sim.pose[rows, k]
        cols[f"{name}_error_m"] = sim.platform_error[rows]
        for i in range(sim.tau.shape[1]):
            cols[f"{name}_tau{i + 1}_Nm"] = sim.tau[rows, i]
        for k, j in enumerate(sim.clearance_joints):
            cols[f"{name}_Fn_{j}_N"] = sim.normal_force[rows, k]
            cols[f"{name}_penetration_{j}_m"] = sim.penetration[rows, k]
            cols[f"{name}_ex_{j}_m"] = sim.eccentricity[rows, k, 0]
            cols[f"{name}_ey_{j}_m"] = sim.eccentricity[rows, k, 1]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        w.writerows(np.column_stack(list(cols.values())).tolist())
    return path


def _fmt(v, scale=1.0, digits=4):
    return "-" if v is None else f"{v * scale:.{digits}g}"


def report_markdown(summary: dict) -> str:
    """A short Markdown report: one table comparing the arms, the preload and the targets."""
    arms = [(k, summary[k]) for k in ("with_preload", "without_preload") if summary.get(k) is not None]
    head = "| metric | " + " | ".join(k.replace("_", " ") for k, _ in arms) + " |"
    rows = [head, "|---" * (len(arms) + 1) + "|"]

    def row(label, f):
        rows.append(f"| {label} | " + " | ".join(f(m) for _, m in arms) + " |")

    row("contact-loss events (all joints, whole run)", lambda m: str(sum(m["contact_loss_events"].values())))
    row("largest free-flight fraction", lambda m: _fmt(max(m["free_flight_fraction"].values(), default=0.0)))
    row("max penetration [um]", lambda m: _fmt(m["max_penetration_m"], 1e6))
    row("peak contact force [N]", lambda m: _fmt(max(m["peak_contact_force_N"].values(), default=0.0)))
    row("smallest contact force [N]", lambda m: _fmt(min(m["min_contact_force_N"].values(), default=None)))
    row("platform error RMS [um]", lambda m: _fmt(m["platform_error_rms_m"], 1e6))
    row("platform error max [um]", lambda m: _fmt(m["platform_error_max_m"], 1e6))
    row("torque RMS [N m]", lambda m: _fmt(m["torque_rms_Nm"]))
    row("energy audit residual", lambda m: _fmt(m["energy_audit_residual"], 1.0, 3))
    row("simulated time [s]", lambda m: _fmt(m["simulated_time_s"]))
    row("integrator, step [s]", lambda m: f"{m['integrator']}, {m['step_s']:g}")
    row("wall time [s]", lambda m: _fmt(m["wall_time_s"], 1.0, 3))

    joints = list(arms[0][1]["contact_loss_events"])
    per = ["", "| joint | " + " | ".join(f"losses {k.replace('_', ' ')}" for k, _ in arms) + " |",
           "|---" * (len(arms) + 1) + "|"]
    for j in joints:
        per.append(f"| {j} | " + " | ".join(str(m["contact_loss_events"][j]) for _, m in arms) + " |")

    pre = summary["preload"]
    if pre.get("method"):
        pre_line = (f"Preload: method `{pre['method']}`, f_min = {pre['f_min_N']:g} N, feasible at "
                    f"{pre['samples'] - pre['infeasible_samples']}/{pre['samples']} path samples, alpha in "
                    f"[{pre['alpha_min_Nm']:.4g}, {pre['alpha_max_Nm']:.4g}] N m.")
    else:
        pre_line = f"No preload arm: {pre['reason']}."
    lines = [f"# Study of `{summary['scene']}`", "", summary["description"], "", pre_line, "", *rows, *per]
    tg = summary.get("targets") or {}
    if tg:
        lines += ["", "Targets: zero losses with preload over the whole run: "
                  f"**{'yes' if tg['zero_losses_with_preload'] else 'no'}**; RMS error with/without = "
                  f"{_fmt(tg['rms_error_ratio_with_to_without'], 1.0, 3)} (target <= 0.5: "
                  f"**{'yes' if tg['rms_error_at_most_half'] else 'no'}**)."]
    journals = summary.get("initial_journals", "centred")
    lines += ["", f"Start: journals {journals}"
              + (" (each clearance journal rests on its bearing wall under the ideal reaction at t = 0; "
                 "with no load, as without preload at rest, it stays centred)." if journals == "seated" else ".")]
    return "\n".join(lines) + "\n"

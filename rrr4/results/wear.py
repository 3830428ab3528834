"""What ``rrr4 wear`` leaves behind (:func:`rrr4.studies.wear.wear_study`): the result types,
its summary, and the result directory (written atomically): wear_profiles.png,
wear_history.png, history.csv, profiles.csv, summary.json and report.md."""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..contact.wear import line_contact_pressure, node_angles, node_depths
from ..scene import Scene
from .output import atomic_directory

__all__ = ["WearArm", "WearStudy", "wear_summary", "write_wear", "PERIODIC", "jump_line"]

PERIODIC = 0.01  # a cycle is periodic when no journal ends farther than this (radial clearances) from its start


@dataclass(frozen=True)
class WearArm:
    """One arm's cycle jumping. joints: the clearance joints that wear (graph order); cycles
    (K + 1,): the cycle counts where a cycle was simulated after the start transient (its
    length first, N last); jumps (K,);
    profiles: joint -> surface -> the profile's B-spline coefficients (M,) [m] after N cycles; volume: joint -> worn
    volume [m^3] after N cycles; records (K + 1): each simulated cycle's platform_error_rms_m /
    _max_m, contact_loss_events (all clearance joints), dissipated_friction_J, and per joint
    (in `joints` order) peak_contact_force_N, peak_layer_pressure_Pa (the conformal layer's
    K_w d^m at the cycle's deepest overlap), volume_m3 and deepest_m of the profiles it ran on,
    wear_per_cycle_m (the deepest depth that cycle added), peak_film_force_N,
    peak_total_force_N, min_film_thickness_m, load_direction_deg (bearing frame), periodicity
    (how far it ended from its start, radial clearances), wall_time_s; wall_time [s];
    transient: the records of the start transient's cycles (run once, not scaled)."""
    name: str
    joints: tuple[str, ...]
    cycles: np.ndarray
    jumps: np.ndarray
    profiles: dict  # joint -> surface -> the profile's coefficients (M,) [m] (rrr4.contact.wear)
    volume: dict
    records: list = field(repr=False)
    wall_time: float = 0.0
    transient: list = field(default_factory=list, repr=False)  # the start transient's records, each cycle once

    def series(self, key: str) -> np.ndarray:
        """The records' `key` over the simulated cycles: (K + 1,) or (K + 1, joints)."""
        return np.array([r[key] for r in self.records], float)


@dataclass(frozen=True)
class WearStudy:
    """`cycles` cycles of `cycle_time` [s] in jumps of at most `max_change` radial clearances;
    arms: name -> WearArm; jump_error: the first arm against half its jumps (None: not run);
    adapted_from: the jump error of the default max_change that made the study run again with
    smaller jumps (None: it did not)."""
    scene: Scene
    cycles: int
    max_change: float
    cycle_time: float
    arms: dict
    jump_error: dict | None = None
    adapted_from: dict | None = None


def _modulus(spec) -> float:
    """E* [Pa] of a clearance joint's materials."""
    s = sum((1.0 - m.poisson_ratio**2) / m.youngs_modulus for m in (spec.journal_material, spec.bearing_material))
    return 1.0 / s


def wear_summary(study: WearStudy) -> dict:
    """JSON-ready numbers of a wear study (units in the key names). Per arm and joint: worn
    volume, deepest depth and where (the bearing angle of the deepest node of the bearing's
    profile, else the journal's), depth over the radial clearance, concentration (the profile's
    largest depth over its mean: 1 for even wear), life_cycles (N plus the cycles until the
    deepest point is one radial clearance deep at the last cycle's rate), the Hertzian line-contact
    pressure of the last cycle's peak contact force on the unworn geometry (an upper bound: the
    worn bore conforms to the journal and spreads the force over a wider arc)."""
    scene = study.scene
    out = {"scene": scene.name, "task": scene.graph.task is not None, "cycles": study.cycles,
           "cycle_time_s": study.cycle_time, "max_change": study.max_change, "jump_error": study.jump_error,
           "adapted_from": study.adapted_from, "arms": {}}
    for name, arm in study.arms.items():
        last = arm.records[-1]
        joints = {}
        for k, j in enumerate(arm.joints):
            spec = scene.graph.joint(j)
            w = scene.effects.wear_of(spec)
            surface = "bearing" if "bearing" in arm.profiles[j] else "journal"
            d = node_depths(arm.profiles[j][surface])
            deepest = float(np.max(d))
            rate = last["wear_per_cycle_m"][k]
            left = spec.radial_clearance - deepest
            joints[j] = {"volume_m3": arm.volume[j], "deepest_m": deepest, "surface": surface,
                         "deepest_at_deg": float(np.degrees(node_angles(len(d))[int(np.argmax(d))])),
                         "deepest_over_clearance": deepest / spec.radial_clearance,
                         # None: nothing wore (report.md writes "no wear")
                         "concentration": deepest / float(np.mean(d)) if np.mean(d) > 0 else None,
                         "life_cycles": (study.cycles + left / rate if rate > 0 and left > 0 else
                                         study.cycles if left <= 0 else None),  # None: it stopped wearing
                         "peak_contact_force_N": last["peak_contact_force_N"][k],
                         "peak_pressure_Pa": _pressure(spec, w, last["peak_contact_force_N"][k]),
                         "peak_layer_pressure_Pa": last.get("peak_layer_pressure_Pa", [None] * len(arm.joints))[k],
                         "hardness_Pa": w.hardness, **_film(scene, spec, last, k)}
        first = arm.records[0]
        out["arms"][name] = {
            "simulated_cycles": len(arm.records), "wall_time_s": arm.wall_time,
            "seconds_per_simulated_cycle": arm.wall_time / len(arm.records),
            "worn_volume_m3": float(sum(arm.volume.values())), "joints": joints,
            "platform_error_rms_m": {"first": first["platform_error_rms_m"], "last": last["platform_error_rms_m"]},
            "platform_error_max_m": {"first": first["platform_error_max_m"], "last": last["platform_error_max_m"]},
            "contact_loss_events_per_cycle": {"first": first["contact_loss_events"],
                                              "last": last["contact_loss_events"],
                                              "max": max(r["contact_loss_events"] for r in arm.records)},
            "start_transient": _transient(scene, arm),
            # how far a steady cycle ended from its start at most (radial clearances): beyond PERIODIC the
            # cycles differ from one another and the jump scales one sample of them
            "steady_periodicity_max": max((r.get("periodicity", 0.0) for r in arm.records), default=0.0)}
    return out


def _pressure(spec, w, force: float) -> float:
    """The peak Hertzian line-contact pressure [Pa] of a normal force [N] at a clearance joint."""
    return float(line_contact_pressure(force, w.length, spec.journal_radius, spec.bearing_radius, _modulus(spec)))


def _film(scene: Scene, spec, record: dict, k: int) -> dict:
    """A lubricated joint's film numbers of a cycle's record: the peak film force [N], the
    peak total force on the journal (dry + film) [N] and the minimum film thickness
    h_min = c (1 - eps) [m]; {} at a dry joint."""
    if scene.effects.lubrication_of(spec).law == "none" or "peak_film_force_N" not in record:
        return {}
    return {"peak_film_force_N": record["peak_film_force_N"][k], "peak_total_force_N": record["peak_total_force_N"][k],
            "min_film_thickness_m": record["min_film_thickness_m"][k]}


def _transient(scene: Scene, arm: WearArm) -> dict | None:
    """The start transient (run once, each cycle wearing once): its cycles, contact losses,
    the peak contact force and pressure per joint over it, and how far its last cycle ended
    from its start (radial clearances); None when the arm has none recorded."""
    if not arm.transient:
        return None
    joints = {}
    for k, j in enumerate(arm.joints):
        spec = scene.graph.joint(j)
        force = max(r["peak_contact_force_N"][k] for r in arm.transient)
        joints[j] = {"peak_contact_force_N": force, "peak_pressure_Pa": _pressure(spec, scene.effects.wear_of(spec),
                                                                                  force),
                     **({"peak_film_force_N": max(r["peak_film_force_N"][k] for r in arm.transient)}
                        if _film(scene, spec, arm.transient[-1], k) else {})}
    end = arm.transient[-1]["periodicity"]
    return {"cycles": len(arm.transient), "contact_loss_events": [r["contact_loss_events"] for r in arm.transient],
            "periodicity": [r["periodicity"] for r in arm.transient],
            "periodic": len(arm.transient) > 1 and end <= PERIODIC, "joints": joints}


def _history_csv(study: WearStudy) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    joints = next(iter(study.arms.values())).joints
    w.writerow(["arm", "cycles", "jump", "platform_error_rms_m", "platform_error_max_m", "contact_loss_events",
                "dissipated_friction_J", *(f"volume_{j}_m3" for j in joints), *(f"deepest_{j}_m" for j in joints)])
    for arm in study.arms.values():
        for k, (n, r) in enumerate(zip(arm.cycles, arm.records, strict=True)):
            w.writerow([arm.name, int(n), int(arm.jumps[k]) if k < len(arm.jumps) else 0,
                        *(f"{r[key]:.9g}" for key in ("platform_error_rms_m", "platform_error_max_m")),
                        r["contact_loss_events"], f"{r['dissipated_friction_J']:.9g}",
                        *(f"{v:.9g}" for v in r["volume_m3"]), *(f"{v:.9g}" for v in r["deepest_m"])])
    return buf.getvalue()


def _profiles_csv(study: WearStudy) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["arm", "joint", "surface", "angle_deg", "depth_m", "coefficient_m"])
    for arm in study.arms.values():
        for j, by in arm.profiles.items():
            for s, c in by.items():
                for a, v, k in zip(np.degrees(node_angles(len(c))), node_depths(c), c, strict=True):
                    w.writerow([arm.name, j, s, f"{a:g}", f"{v:.9g}", f"{k:.9g}"])
    return buf.getvalue()


def _report(summary: dict) -> str:
    lines = [f"# Wear of {summary['scene']}: {summary['cycles']:g} cycles of {summary['cycle_time_s']:g} s", "",
             f"Cycle jumping: the profile's deepest change per jump is at most {summary['max_change']:g} radial "
             "clearances.", ""]
    je, first = summary["jump_error"], summary.get("adapted_from")
    if first:
        lines += [f"Adapted: the default jumps ({first['max_change']:g} c) differed by {first['profile_error']:.2g} of "
                  f"the deepest depth from jumps half as large (more than {first['tolerance']:g}), so the study ran "
                  f"again with jumps of at most {summary['max_change']:g} c; what follows is that run.", ""]
    if je:
        worst = max(je["volume_error"].values(), default=0.0)
        lines += [f"Jump error ({je['arm'].replace('_', ' ')}, against jumps of at most {je['finer_max_change']:g} "
                  f"clearances): profile {je['profile_error']:.2g} of the deepest depth, worn volume "
                  f"{worst:.2g} at most.", ""]
        if je.get("suggested_max_change") is not None:
            lines += [f"**The jumps are too coarse:** {jump_line(je)}.", ""]
    for name, arm in summary["arms"].items():
        error = arm["platform_error_rms_m"]
        error = (f"platform error RMS {error['first'] * 1e6:.3g} um in cycle 0 -> {error['last'] * 1e6:.3g} um in the "
                 "last; " if summary["task"] else "")
        lines += [f"## {name.replace('_', ' ')}", "",
                  f"{arm['simulated_cycles']} cycles simulated in {arm['wall_time_s']:.1f} s; worn volume "
                  f"{arm['worn_volume_m3']:.3g} m^3; {error}contact losses per cycle "
                  f"{arm['contact_loss_events_per_cycle']['first']} -> {arm['contact_loss_events_per_cycle']['last']}.",
                  "",
                  "| joint | volume [m^3] | deepest [um] | at [deg] | deepest / c | peak / mean depth | "
                  "life [cycles] | Hertz pressure of the peak force [MPa] | layer's peak pressure [MPa] |",
                  "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
        for j, r in arm["joints"].items():
            lines.append(f"| {j} | {r['volume_m3']:.3g} | {r['deepest_m'] * 1e6:.3g} | {r['deepest_at_deg']:g} | "
                         f"{r['deepest_over_clearance']:.3g} | "
                         f"{'no wear' if r['concentration'] is None else format(r['concentration'], '.3g')} | "
                         f"{_g(r['life_cycles'])} | {r['peak_pressure_Pa'] / 1e6:.4g} | "
                         f"{_g(None if r['peak_layer_pressure_Pa'] is None else r['peak_layer_pressure_Pa'] / 1e6)} |")
        lines += ["", *_film_lines(arm), *_transient_lines(arm["start_transient"])]
        if arm["steady_periodicity_max"] > PERIODIC:
            why = ("rattling" if arm["contact_loss_events_per_cycle"].get("max", 1) else
                   "no contact was lost: the mechanism settling onto the grooves a jump deepened")
            lines += [f"The cycles are not periodic: a steady cycle ended up to {arm['steady_periodicity_max']:.2g} "
                      f"radial clearances from where it started ({why}). Each jump scales one sample of cycles that "
                      "differ, so the jump error measures their variability as well as the jump; smaller jumps "
                      "(--max-change) simulate and average more of them.", ""]
    lines += ["life: the cycles until the deepest point of the profile is one radial clearance deep, extrapolated "
              "at the last cycle's wear rate. Hertz pressure: the line-contact pressure of the last cycle's peak force "
              "on the unworn geometry, an upper bound once the bore conforms to the journal (the last cycle is a "
              "steady one: each cycle starts where the last ended; the start transient is reported apart). "
              "Layer's peak pressure: the conformal layer's K_w d^m at the last cycle's deepest overlap d, on the "
              "worn profile (its elastic pressure; K_w matched to the dry law on the unworn bore). "
              "Angles: the bearing angle in the bearing body's frame.", ""]
    return "\n".join(lines)


def _film_lines(arm: dict) -> list[str]:
    """The lubricated joints' film in the last (steady) cycle, one table; none at dry joints."""
    films = {j: r for j, r in arm["joints"].items() if "peak_film_force_N" in r}
    if not films:
        return []
    return ["| lubricated joint | peak film force [N] | peak dry force [N] | peak total force [N] | "
            "min film thickness h_min [um] |", "| --- | --- | --- | --- | --- |",
            *(f"| {j} | {r['peak_film_force_N']:.4g} | {r['peak_contact_force_N']:.4g} | {r['peak_total_force_N']:.4g} "
              f"| {r['min_film_thickness_m'] * 1e6:.3g} |" for j, r in films.items()), ""]


def _transient_lines(t: dict | None) -> list[str]:
    """The start transient, reported apart from the steady cycles."""
    if t is None:
        return []
    peak = ", ".join(f"{j} {r['peak_contact_force_N']:.4g} N ({r['peak_pressure_Pa'] / 1e6:.4g} MPa)"
                     for j, r in t["joints"].items())
    state = (f"periodic: its last cycle ended {t['periodicity'][-1]:.2g} radial clearances from where it started"
             if t["periodic"] else f"not periodic after {t['cycles']} cycles: the last ended "
             f"{t['periodicity'][-1]:.2g} radial clearances from its start (the jumps scale a cycle that still varies)")
    return [f"Start transient, run once and not scaled: {t['cycles']} cycles from the scene's initial state, contact "
            f"losses {t['contact_loss_events']}, peak contact force {peak}; {state}.", ""]


def jump_line(error: dict) -> str:
    """One line when the measured jump error exceeds its tolerance, with the max_change to use."""
    return (f"max_change: {error['max_change']:g} lets the profile differ by {error['profile_error']:.2g} of its "
            f"deepest depth from jumps half as large (more than {error['tolerance']:g}); use --max-change "
            f"{error['suggested_max_change']:.2g} or less")


def _g(v) -> str:
    return "-" if v is None else f"{v:.3g}"


def write_wear(study: WearStudy, out) -> tuple[dict, list[str]]:
    """Write the wear study into `out` atomically. Returns (summary, file names)."""
    from .figures.wear import plot_wear_history, plot_wear_profiles
    summary = wear_summary(study)
    names: list[str] = []

    def fill(tmp: Path) -> None:
        (tmp / "history.csv").write_text(_history_csv(study))
        (tmp / "profiles.csv").write_text(_profiles_csv(study))
        (tmp / "report.md").write_text(_report(summary))
        plot_wear_profiles(study, tmp / "wear_profiles.png")
        plot_wear_history(study, tmp / "wear_history.png")
        (tmp / "summary.json").write_text(json.dumps(summary, indent=1, default=float) + "\n")
        names.extend(sorted(p.name for p in tmp.iterdir()))

    atomic_directory(Path(out), fill)
    return summary, names

"""Method 'staged' on the full record of a perturbed reference plant (issue 46): accuracy, wall
time, the compensated controller with the identified model, and the figures of
docs/identification.md.

    .venv/bin/python benchmarks/bench_identify_staged.py [--t-end 1.0] [--windows 1] [--figures docs/figures]
    .venv/bin/python benchmarks/bench_identify_staged.py --seeds 1:13 [--t-end 1.0]

The plant: problems/paper_circle.yaml with every clearance changed (70 to 130 um), friction
0.15, contact stiffness 1e10 N/m^1.5 and the second chain's driving link 150 um longer (the
truth of tests/test_identify_staged.py), run for --t-end s under the nominal controller,
sampled at 1 kHz, noise 1 um (position), 1e-5 rad (orientation, actuator angles), 1 % of each
effort's RMS (seed 1), the noise levels given. It prints the staged fit's table, each
parameter's error in standard errors, the wall time of identify (the simulation of the plant
not counted; compiled stepping, the sensitivity frames found in the on-disk cache after the
first run), and the compensated controller's platform error on the plant with the identified,
the nominal and the true model. With --figures it writes identification_staged_fit.png and
identification_staged_intervals.png there. With --seeds A:B it fits the record of each noise
seed from A to B-1 instead (no compensated runs, no figures) and prints, per parameter, how
many 95 % intervals hold the truth and the RMS of the errors in standard errors (the
stiffness's in log K, the coordinate it is fitted in): coverage by simulation on the plant
itself. Load average before and after.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

import rrr4
from rrr4.identify import Measurements, identify, measurements_from_simulation
from rrr4.problem import Problem
from rrr4.studies.study import arm_scene

ROOT = Path(__file__).resolve().parent.parent
JOINTS = ("B1", "B2", "B3", "B4", "C1", "C2", "C3", "C4")
CLEARANCES = dict(zip([f"joints.per_joint.{j}.radial_clearance" for j in JOINTS],
                      [125e-6, 78e-6, 112e-6, 71e-6, 86e-6, 129e-6, 93e-6, 118e-6], strict=True))
LINK = "mechanism.chains[1].driving_link.length"
TRUTH = {**CLEARANCES, "effects.friction.coefficient": 0.15, "effects.contact.stiffness": 1.0e10, LINK: 0.25 + 150e-6}


def measured(t_end: float, seed: int = 1):
    nominal = rrr4.load_scene(ROOT / "problems" / "paper_circle.yaml")
    plant = nominal.with_values(TRUTH, name="plant")
    clean = measurements_from_simulation(rrr4.simulate(plant, t_end=t_end, model=nominal, output_rate=1000))
    noise = {"x_m": 1e-6, "y_m": 1e-6, "theta_rad": 1e-5,
             **{c: 1e-5 for c in clean.columns if c.startswith("theta_A")},
             **{c: 0.01 * float(np.sqrt(np.mean(v ** 2))) for c, v in clean.columns.items() if c.startswith("tau_")}}
    rng = np.random.default_rng(seed)
    cols = {c: clean.columns[c] + s * rng.standard_normal(len(clean.t)) for c, s in noise.items()}
    return nominal, plant, Measurements(clean.t, cols, {}, "noisy plant"), noise


def compensated_error(plant, model, t_end: float) -> float:
    """RMS platform error [m] of the compensated controller with `model` (None: the plant's own) on `plant`."""
    arm = "with_preload_compensated"
    plant_problem = Problem.from_scene(plant)
    kw = {} if model is None else {"model": arm_scene(Problem.from_scene(model), arm)}
    sim = rrr4.simulate(arm_scene(plant_problem, arm), t_end=t_end, **kw)
    return float(np.sqrt(np.mean(sim.platform_error ** 2)))


def figures(res, out: Path) -> list[Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    out.mkdir(parents=True, exist_ok=True)
    t = res.t
    fig, ax = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    for a, c in zip(ax[:2], ("x_m", "y_m"), strict=True):
        meas = (res.explained[c] + res.residual[c]) * 1e6
        a.plot(t, meas, ".", ms=2, color="0.6", label="measured (offset from the path)")
        a.plot(t, res.explained[c] * 1e6, "C0", lw=1.2, label="staged fit (dynamic stage)")
        a.set_ylabel(f"{c[0]} offset [um]")
        a.legend(loc="upper right", fontsize=8)
    for c, col in (("x_m", "C1"), ("y_m", "C2")):
        ax[2].plot(t, res.residual[c] * 1e6, color=col, lw=0.6, label=f"{c[0]} residual")
    ax[2].set_ylabel("residual [um]")
    ax[2].set_xlabel("t [s]")
    ax[2].legend(loc="upper right", fontsize=8)
    fig.suptitle(f"Staged identification of the perturbed reference plant: platform offset, {t[-1]:g} s at 1 kHz")
    fig.tight_layout()
    fit_png = out / "identification_staged_fit.png"
    fig.savefig(fit_png, dpi=110)
    plt.close(fig)

    seated = res.fit["stages"][0].get("estimate", {})
    keys = res.keys
    lengths = [k for k in keys if "clearance" in k or "length" in k]
    fig, ax = plt.subplots(1, 3, figsize=(12, 4.5), gridspec_kw={"width_ratios": [4, 1, 1]})
    x = np.arange(len(lengths))
    for i, k in enumerate(lengths):
        j = keys.index(k)
        err, (lo, hi) = (res.estimate[j] - TRUTH[k]) * 1e6, (res.interval[j] - TRUTH[k]) * 1e6
        ax[0].errorbar(i, err, yerr=[[err - lo], [hi - err]], fmt="o", color="C0", capsize=3,
                       label="staged: estimate - truth, 95 % interval" if i == 0 else None)
        if k in seated:
            ax[0].plot(i + 0.15, (seated[k] - TRUTH[k]) * 1e6, "x", color="C3",
                       label="seated stage alone" if i == 0 else None)
    ax[0].axhline(0, color="k", lw=0.8)
    ax[0].axhspan(-5, 5, color="C2", alpha=0.12, label="within 5 um")
    ax[0].set_xticks(x, [k.replace("joints.per_joint.", "").replace(".radial_clearance", "").replace(
        "mechanism.chains[1].driving_link.length", "l1 (chain 2)") for k in lengths])
    ax[0].set_ylabel("error [um]")
    ax[0].set_ylim(-30, 30)
    ax[0].legend(fontsize=8, loc="lower left")
    for a, k, unit in ((ax[1], "effects.friction.coefficient", ""),
                       (ax[2], "effects.contact.stiffness", " [N/m^1.5]")):
        j = keys.index(k)
        e, (lo, hi) = res.estimate[j], res.interval[j]
        if k == "effects.contact.stiffness":  # fitted in log(K): its interval there, +-1.96 se / K
            lo, hi = e * np.exp(-1.96 * res.standard_error[j] / e), e * np.exp(1.96 * res.standard_error[j] / e)
            a.set_yscale("log")
        scale = 1.0
        a.errorbar(0, e, yerr=[[e - lo], [hi - e]], fmt="o", color="C0", capsize=3)
        a.axhline(TRUTH[k] * scale, color="k", lw=0.8, label="truth")
        if k in seated:
            a.plot(0.15, seated[k] * scale, "x", color="C3")
        a.set_xticks([0], [k.split(".")[1] + unit])
        a.set_xlim(-0.5, 0.5)
        a.legend(fontsize=8)
    fig.suptitle("Estimates against the truth (the seated stage's estimate marked x)")
    fig.tight_layout()
    int_png = out / "identification_staged_intervals.png"
    fig.savefig(int_png, dpi=110)
    plt.close(fig)
    return [fit_png, int_png]


def coverage(a: int, b: int, t_end: float, windows: int) -> None:
    """Per parameter: the 95 % intervals that hold the truth over the seeds a..b-1, and the RMS
    of the errors in standard errors (log K for the stiffness)."""
    keys, truth = list(TRUTH), np.array(list(TRUTH.values()))
    log = np.array(["stiffness" in k for k in keys])
    inside, z, walls = [], [], []
    for seed in range(a, b):
        nominal, _, m, noise = measured(t_end, seed)
        wall = time.perf_counter()
        res = identify(nominal, m, keys, noise=noise, windows=windows)
        walls.append(time.perf_counter() - wall)
        lo, hi = res.interval.T
        inside.append((lo <= truth) & (truth <= hi))
        est, tru = np.where(log, np.log(res.estimate), res.estimate), np.where(log, np.log(truth), truth)
        se = np.where(log, (np.log(hi) - np.log(lo)) / (2 * 1.959963984540054), res.standard_error)
        z.append((est - tru) / se)
        outside = [k for k, i in zip(keys, inside[-1], strict=True) if not i]
        print(f"seed {seed}: {walls[-1]:.1f} s, converged {res.fit['converged']}, errors in standard errors "
              + " ".join(f"{v:+.2f}" for v in z[-1]) + f", outside: {outside}", flush=True)
    inside, z = np.array(inside), np.array(z)
    print(f"{len(z)} seeds, identify median {np.median(walls):.1f} s")
    print(f"{'parameter':45s} {'inside':>8s} {'RMS z':>7s} {'mean z':>7s}")
    for j, k in enumerate(keys):
        print(f"{k:45s} {int(inside[:, j].sum()):3d}/{len(z):<4d} {np.sqrt(np.mean(z[:, j] ** 2)):7.2f} "
              f"{np.mean(z[:, j]):+7.2f}")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--windows", type=int, default=1)
    ap.add_argument("--figures", type=Path)
    ap.add_argument("--no-control", action="store_true", help="skip the compensated runs")
    ap.add_argument("--seeds", help="A:B: coverage over the noise seeds A..B-1 (no compensated runs, no figures)")
    args = ap.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f}", flush=True)
    if args.seeds:
        coverage(*(int(v) for v in args.seeds.split(":")), args.t_end, args.windows)
        print(f"load average after: {os.getloadavg()[0]:.2f}")
        return
    nominal, plant, m, noise = measured(args.t_end)
    wall = time.perf_counter()
    res = identify(nominal, m, list(TRUTH), noise=noise, windows=args.windows)
    wall = time.perf_counter() - wall
    print(res.table())
    print(f"identify (staged, {len(TRUTH)} parameters, {len(m)} instants): {wall:.1f} s")
    for k in res.keys:
        j = res.keys.index(k)
        e = res.estimate[j] - TRUTH[k]
        unit = (1e6, "um") if ("clearance" in k or "length" in k) else (1.0, "")
        print(f"  {k:45s} error {e * unit[0]:+.3g} {unit[1]} ({e / res.standard_error[j]:+.2f} standard errors)")
    if not args.no_control:
        errors = {name: compensated_error(plant, model, args.t_end) for name, model in
                  (("identified", res.identified), ("nominal", nominal), ("true", None))}
        print("compensated controller on the plant, RMS platform error: " +
              ", ".join(f"{k} model {1e6 * v:.3g} um" for k, v in errors.items()))
    if args.figures:
        for p in figures(res, args.figures):
            print("wrote", p)
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()

"""ns per call of the generated controller step of a graph scene (the table step: references
tabulated along the path, binary search, piecewise cubics, feedback law) against the
closed-form n-RRR step of the same mechanism, and each against its CasADi Function called
from Python, in one run on one machine.

    python benchmarks/bench_codegen_graph.py [--calls N] [--repeats R] [--loop] [--convergence]

Scenes: problems/paper_circle_graph.yaml (the reference 4-RRR written as a graph) and
problems/paper_circle.yaml (the same mechanism, closed form). Each step is compiled with
gcc -O3 in a small timing harness next to its generated sources and called round-robin over
64 instants of the path with a 1 mrad tracking error; the harnesses run in turns, R
repeats of N calls each, and the median per call is reported. The Python side calls the
same step's CasADi Function with numpy arrays (median of R repeats of 0.3 s).

--loop: also simulate the shipped graph scenes (the five-bar sampled at 10 kHz, as
paper_circle_graph is) over their whole path with the Python controller and with the
generated C in the loop, with and without clearance compensation: the largest differences
of pose and efforts, the contact losses of each, and the stepping's wall time of each
(medians of 3 runs, compiled stepping, compilation excluded).

--convergence: the table step of paper_circle_graph against the closed-form step of
paper_circle (an independent IK and inverse dynamics) at the midpoints between the table's
instants, as the path's sample rate doubles from 125 to 2000 Hz, without preload and with
the exact and qp preloads: the largest errors of theta_ref, theta_d_ref, tau_ff and alpha.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

import rrr4
from rrr4.codegen import build_example, codegen
from rrr4.codegen.build import machine
from rrr4.control import controller_step, step_inputs
from rrr4.control import reference_grid as table_grid

ROOT = Path(__file__).resolve().parents[1]
SCENES = {"graph (table step)": "paper_circle_graph.yaml", "n-RRR (closed form)": "paper_circle.yaml"}
SAMPLES = 64

_HARNESS = r"""/* timing harness of rrr4_controller_step: prints 'ns_per_call' per repeat */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "rrr4.h"

#define S __SAMPLES__
#define N RRR4_N_ACTUATORS
static double T[S], P[S][3], PD[S][3], PDD[S][3], TH[S][N], THD[S][N], tau[N];
volatile double sink;

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

int main(int argc, char **argv) {
  long calls = atol(argv[1]), c;
  int repeats = atoi(argv[2]), s, i, r;
  for (s = 0; s < S; ++s) {
    double ref[N], ref_d[N];
    T[s] = RRR4_PATH_DURATION * (s + 0.5) / S;
    rrr4_trajectory(T[s], P[s], PD[s], PDD[s]);
    for (i = 0; i < N; ++i) TH[s][i] = THD[s][i] = 0.0;
    rrr4_controller_step(__INPUTS__, TH[s], THD[s], NULL, NULL, ref, ref_d, NULL, NULL);
    for (i = 0; i < N; ++i) {
      TH[s][i] = ref[i] - 1e-3;
      THD[s][i] = ref_d[i];
    }
  }
  for (r = 0; r < repeats; ++r) {
    double t0 = now();
    for (c = 0; c < calls; ++c) {
      s = (int)(c % S);
      rrr4_controller_step(__INPUTS__, TH[s], THD[s], tau, NULL, NULL, NULL, NULL, NULL);
      sink += tau[0];
    }
    printf("%.3f\n", 1e9 * (now() - t0) / calls);
  }
  return 0;
}
"""


def _c_times(problem, tmp: Path, calls: int, repeats: int) -> list[float]:
    """ns per call of the step's C, one per repeat."""
    src = tmp / problem.name
    codegen(problem, src)
    inputs = "T[s]" if controller_step(problem).name_in(0) == "t" else "P[s], PD[s], PDD[s]"
    (src / "main.c").write_text(_HARNESS.replace("__SAMPLES__", str(SAMPLES)).replace("__INPUTS__", inputs))
    exe = build_example(src, tmp / f"{problem.name}_bench", flags=("-O3", "-Wall"))
    out = subprocess.run([str(exe), str(calls), str(repeats)], capture_output=True, text=True, check=True).stdout
    return [float(v) for v in out.split()]


def _python_time(problem, seconds: float = 0.3) -> float:
    """ns per call of the step's CasADi Function from Python (one call per instant)."""
    step = controller_step(problem)
    n = problem.model.n_actuators
    t = problem.path.duration * (np.arange(SAMPLES) + 0.5) / SAMPLES
    ins = step_inputs(step, problem.path, t)
    refs = [np.array(v) for v in step.map(SAMPLES)(*ins, np.zeros((n, SAMPLES)), np.zeros((n, SAMPLES)))]
    args = [[v[:, s] for v in ins] + [refs[2][:, s] - 1e-3, refs[3][:, s]] for s in range(SAMPLES)]
    calls, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        step(*args[calls % SAMPLES])
        calls += 1
    return 1e9 * (time.perf_counter() - start) / calls


def compare_in_the_loop() -> None:
    """Python arm against the generated C in the loop on the graph scenes (see --loop)."""
    print(f"{'scene':<20} {'compensation':<13} {'max|dpose|':>10} {'max|dtau|':>10} {'losses':>7} "
          f"{'python [s]':>10} {'C [s]':>7}")
    for name in ("redundant_five_bar.yaml", "paper_circle_graph.yaml"):
        scene = rrr4.load_scene(ROOT / "problems" / name)
        a = scene.actuation
        for comp in ("none", "clearance"):
            s = replace(scene, actuation=replace(a, control_rate=a.control_rate or 1e4, compensation=comp))
            runs = {c: [rrr4.simulate(s, controller=c, jit=True) for _ in range(3)] for c in ("python", "generated")}
            p, g = runs["python"][0], runs["generated"][0]
            wall = {c: float(np.median([r.stats["wall_time"] for r in v])) for c, v in runs.items()}
            losses = f"{sum(p.contact_loss_events.values())}/{sum(g.contact_loss_events.values())}"
            print(f"{scene.name:<20} {comp:<13} {np.abs(p.pose - g.pose).max():>10.3g} "
                  f"{np.abs(p.tau - g.tau).max():>10.3g} {losses:>7} {wall['python']:>10.2f} {wall['generated']:>7.2f}")


def convergence() -> None:
    """The table step against the closed form between its instants (see --convergence)."""
    g0, n0 = (rrr4.load_scene(ROOT / "problems" / f) for f in ("paper_circle_graph.yaml", "paper_circle.yaml"))
    print(f"{'preload':<8} {'rate [Hz]':>9} {'theta_ref [rad]':>16} {'theta_d_ref [rad/s]':>20} {'tau_ff [N m]':>13} "
          f"{'alpha [N m]':>12}")
    for method in ("none", "exact", "qp"):
        for rate in (125.0, 250.0, 500.0, 1000.0, 2000.0):
            g, n = (rrr4.build(replace(s, path=replace(s.path, sample_rate=rate), actuation=replace(
                s.actuation, control_rate=None, preload=replace(s.actuation.preload, method=method))))
                    for s in (g0, n0))
            f, h = controller_step(g), controller_step(n)
            t_s = table_grid(g)
            t = 0.5 * (t_s[1:] + t_s[:-1])
            z = np.zeros((4, len(t)))
            a = [np.array(v) for v in f.map(len(t))(t[None, :], z, z)]
            b = [np.array(v) for v in h.map(len(t))(*step_inputs(h, n.path, t), z, z)]
            e = [np.abs((a[2] - b[2] + np.pi) % (2 * np.pi) - np.pi).max(), *(np.abs(a[k] - b[k]).max()
                                                                              for k in (3, 1, 4))]
            print(f"{method:<8} {rate:>9g} {e[0]:>16.2e} {e[1]:>20.2e} {e[2]:>13.2e} {e[3]:>12.2e}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=200000, help="C calls per repeat (default 200000)")
    ap.add_argument("--repeats", type=int, default=7, help="repeats (default 7)")
    ap.add_argument("--convergence", action="store_true", help="only the table step's error between its instants "
                                                               "against the closed form, as the sample rate doubles")
    ap.add_argument("--loop", action="store_true", help="also compare the Python and generated controllers in the "
                                                        "loop on the graph scenes")
    args = ap.parse_args(argv)
    if args.convergence:
        convergence()
        return 0
    problems = {k: rrr4.build(rrr4.load_scene(ROOT / "problems" / v)) for k, v in SCENES.items()}
    for p in problems.values():
        controller_step(p)  # the table is built before any timing
    with tempfile.TemporaryDirectory() as tmp:
        c = {k: [] for k in problems}
        for _ in range(3):  # harnesses in turns
            for k, p in problems.items():
                c[k] += _c_times(p, Path(tmp), args.calls, args.repeats)
    py = {k: float(np.median([_python_time(p) for _ in range(args.repeats)])) for k, p in problems.items()}
    print(f"machine: {machine()}; load average {os.getloadavg()[0]:.2f} (uptime)")
    print(f"{'controller step':<22} {'C -O3 [ns]':>11} {'CasADi from Python [ns]':>24} {'ratio':>7}")
    for k in problems:
        med = float(np.median(c[k]))
        print(f"{k:<22} {med:>11.0f} {py[k]:>24.0f} {py[k] / med:>7.0f}")
    base = float(np.median(c["n-RRR (closed form)"]))
    print(f"table step / closed-form step in C: {float(np.median(c['graph (table step)'])) / base:.2f}")
    if args.loop:
        compare_in_the_loop()
    print(f"load average at the end {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

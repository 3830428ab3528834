"""ns per right-hand side (RHS) of the simulation ODE, compiled, this tree against another.

The ODE is the one the integrators step (:func:`rrr4.simulation.problem_system`; in trees
before the shared controller, the scene's equations with closed-form references and a
given preload: y' = f(t, y, z, u)). Each tree's ODE is built in
its own process from its own sources, saved, and loaded here; both are compiled with the
same flags as the simulation's compiled stepping, inside a chain of K dependent calls
(y <- y + 1e-9 f(t, y, z, u), a ``mapaccum``), so the loop runs in C and no input
conversion is timed. The two are timed interleaved in one process, medians of repeats, and the
ratio after / before is printed with the SX instruction counts and the machine.

    .venv/bin/python benchmarks/bench_rhs.py --before-tree ../rrr4-old [SCENE]

(make ../rrr4-old with ``git worktree add ../rrr4-old <commit>``). Without --before-tree,
only this tree is timed. With --references, this tree's three right-hand sides are timed
against each other instead: the continuous controller step evaluated in the RHS ('exact'),
the feedback law on interpolated references ('sampled'), and the sampled controller's held
efforts (a control rate: the RHS evaluates no controller at all). With --coordinates, the
scene's ODE in reference-point coordinates against the same in tree coordinates (its
integrator.coordinates set to each).
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import casadi as ca
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BUILD = """
import sys
sys.path.insert(0, sys.argv[1])
import rrr4
scene = rrr4.load_scene(sys.argv[2])
try:  # this tree: the problem layer
    from rrr4.simulation import problem_system
    ode = problem_system(rrr4.build(scene)).ode
except ImportError:
  try:  # trees before it: the controller in the loop
    from rrr4.simulation import scene_system
    ode = scene_system(scene).ode
  except ImportError:  # trees before it: references in the right-hand side, preload given
    from rrr4.dynamics.builder import build_equations
    from rrr4.simulation import _system, reference_function
    ode = _system(build_equations(scene), reference_function(scene, False)).ode
ode.save(sys.argv[3])
"""


def build_ode(tree: Path, scene: Path, out: Path) -> ca.Function:
    subprocess.run([sys.executable, "-c", BUILD, str(tree), str(scene), str(out)], check=True, cwd=tree)
    return ca.Function.load(str(out))


def chain(ode: ca.Function, K: int) -> ca.Function:
    """MX Function 'rhs_chain': t, y, z, u -> y after K steps y <- y + 1e-9 f(t, y, z, u)."""
    t, y, z, u = (ca.MX.sym(n, ode.size1_in(i)) for i, n in enumerate(("t", "y", "z", "u")))
    step = ca.Function("step", [y, t, z, u], [y + 1e-9 * ode(t, y, z, u)])
    acc = step.mapaccum("acc", K)
    out = acc(y, ca.repmat(t, 1, K), ca.repmat(z, 1, K), ca.repmat(u, 1, K))
    return ca.Function("rhs_chain", [t, y, z, u], [out[:, -1]])


def inputs(ode: ca.Function, scene_path: Path, seed: int = 0):
    """One state near the scene's start: q, qd from the closed-form motion plus noise of the
    size of the clearance (in tree coordinates if the ODE steps them), half the joints in
    contact, random torques, the scene's parameters and controller settings."""
    import rrr4
    from rrr4.mechanism import Mechanism
    scene = rrr4.load_scene(scene_path)
    mech = Mechanism.from_scene(scene)
    rng = np.random.default_rng(seed)
    nq, nz, nu = mech.nq, ode.size1_in(2), ode.size1_in(3)
    q, qd, _ = mech.body_motion([0.0, 0.0, 0.0], [0.1, 0.05, 0.2])
    q, qd = q + 5e-5 * rng.normal(size=nq), qd + 1e-2 * rng.normal(size=nq)
    y = np.zeros(ode.size1_in(1))
    n = (y.size - 3) // 2
    if n != nq:  # tree coordinates
        q, qd = (np.array(v).ravel() for v in rrr4.build(scene).equations().tree_coordinates(q, qd))
    y[:n], y[n:2 * n] = q, qd
    nc = len(scene.clearance_joints)
    z = np.r_[np.full(nc, 0.05), rng.integers(0, 2, nc), np.zeros(nc)]
    if nz > 3 * nc:  # this tree's ODE carries the parameters (and the controller's settings) after the contact state
        try:
            from rrr4.control import controller_settings
            # the controller's settings; a feedback law's are their prefix (kp, kd, limits)
            problem = rrr4.build(scene)
            rest = np.r_[problem.equations().parameters, controller_settings(problem)]
        except (ImportError, AttributeError):  # an older tree: the contact parameters only
            from rrr4.dynamics.builder import contact_parameters
            rest = contact_parameters(scene)
        z = np.r_[z, rest[:nz - z.size]]
        z = np.r_[z, np.zeros(nz - z.size)]  # a tree whose z ends in running peaks, which the ODE does not read
    u = np.r_[0.0, 1e-3, rng.normal(size=nu - 2)]
    return 5e-4, y, z, u


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", nargs="?", default=str(ROOT / "problems" / "paper_circle.yaml"))
    ap.add_argument("--before-tree", help="source tree of the version to compare against")
    ap.add_argument("--batch", type=int, default=2000, help="RHS calls per compiled call (K)")
    ap.add_argument("--repeat", type=int, default=41)
    ap.add_argument("--references", action="store_true", help="compare this tree's reference variants")
    ap.add_argument("--coordinates", action="store_true",
                    help="compare the scene's ODE in reference-point and in tree coordinates")
    args = ap.parse_args(argv)
    from rrr4.integrators.compiled import compiled
    scene = Path(args.scene).resolve()
    if args.coordinates:
        from dataclasses import replace

        import rrr4
        from rrr4.simulation import problem_system
        sc = rrr4.load_scene(scene)
        odes = {c: problem_system(rrr4.build(replace(sc, integrator=replace(sc.integrator, coordinates=c)))).ode
                for c in ("reference-point", "tree")}
    elif args.references:
        from dataclasses import replace

        import rrr4
        from rrr4.simulation import problem_system
        sc = rrr4.load_scene(scene)
        cont = replace(sc, actuation=replace(sc.actuation, control_rate=None))
        odes = {"exact (controller step in the RHS)": problem_system(rrr4.build(cont), "exact").ode,
                "sampled (feedback on interpolated references)": problem_system(rrr4.build(cont), "sampled").ode,
                "held (sampled controller, zero-order hold)": problem_system(rrr4.build(replace(
                    sc, actuation=replace(sc.actuation, control_rate=sc.actuation.control_rate or 1e4)))).ode}
    else:
        with tempfile.TemporaryDirectory() as tmp:
            trees = {"after (this tree)": ROOT}
            if args.before_tree:
                trees = {"before": Path(args.before_tree).resolve(), **trees}
            odes = {k: build_ode(t, scene, Path(tmp) / f"ode{i}.casadi") for i, (k, t) in enumerate(trees.items())}
    fs = {k: compiled(chain(f, args.batch)) for k, f in odes.items()}
    ins = {k: inputs(f, scene) for k, f in odes.items()}
    outs = {k: np.array(f(*ins[k])) for k, f in fs.items()}
    if len(outs) == 2 and not args.coordinates:
        a, b = outs.values()
        print(f"max relative difference of the two chains' results on the same inputs: "
              f"{np.max(np.abs(a - b)) / np.max(np.abs(a)):.3g}")
    times = {k: [] for k in fs}
    for _ in range(args.repeat):
        for k, f in fs.items():
            t0 = time.perf_counter()
            f(*ins[k])
            times[k].append((time.perf_counter() - t0) / args.batch * 1e9)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores; scene {scene.name}; "
          f"{args.repeat} repeats of {args.batch} chained RHS each, medians")
    print("| ODE | SX instructions | ns per RHS (median) | min |")
    print("|---|---|---|---|")
    med = {}
    for k, f in odes.items():
        med[k] = float(np.median(times[k]))
        print(f"| {k} | {f.n_instructions()} | {med[k]:.0f} | {min(times[k]):.0f} |")
    if len(med) == 2:
        before, after = med.values()
        print(f"ratio after / before: {after / before:.3f}")
    elif len(med) == 3:
        base = next(iter(med.values()))
        print("ratios to the first: " + ", ".join(f"{k} {v / base:.3f}" for k, v in med.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())

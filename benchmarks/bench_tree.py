"""Do tree coordinates pay for the implicit methods? (issue: fast contact dynamics, item 5)

rrr4 integrates reference-point coordinates: every body has [x, y, theta], ideal joints are
constraints (Baumgarte-stabilised, eliminated in the index-1 acceleration), so the implicit
methods' Newton runs on nq = 3 x bodies velocities (27 on the 4-RRR). Where the ideal
joints form a tree rooted at the ground (the 4-RRR: each driving link pinned to the ground;
the clearance joints are force elements, not constraints), minimal coordinates drop them:
a pinned body keeps only its angle, so the 4-RRR has 19 coordinates and no constraint.

This script builds that tree system from the library's own equations, by the velocity
transformation (q = g(p), qd = J pd, J^T M J pdd = J^T (Q - M Jdot pd), with Q the applied
forces of the builder's residual at zero acceleration and multipliers), steps it with the
same integrator, controller and frame inputs as ``rrr4.simulate``, and prints, in one
process, interleaved, medians of repeats: the stepping time of each, their ratio, the SX
instructions of each ODE, and the largest platform-position difference between the two
motions (they integrate the same physics, so it is integration error, not modelling).

    .venv/bin/python benchmarks/bench_tree.py [SCENE] [--t-end 1.0] [--repeats 5] [--step S] [--no-preload]

Only graphs whose ideal joints are revolute joints forming a tree from the ground, without
drivers, are handled (the n-RRR scenes); anything else is refused in one line.
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import rrr4  # noqa: E402
from rrr4.integrators.base import System  # noqa: E402
from rrr4.mechanism.graph import GROUND, rotation  # noqa: E402


def tree_map(model):
    """(p symbols, q(p) (nq,) expression, keep (n_p,) indices of q that are p): every body
    joined to an already placed body (or the ground) by an ideal revolute joint keeps only
    its angle; the others keep [x, y, theta]."""
    graph = model.graph
    if graph.drivers:
        raise SystemExit("bench_tree: scenes with drivers are not handled by this prototype")
    parent = {}
    for name in model.constrained_joints:
        j = graph.joint(name)
        if j.type != "revolute":
            raise SystemExit(f"bench_tree: ideal joint {name} is {j.type}; only revolute trees are handled")
        a, b = j.bodies
        if a == GROUND or b == GROUND:
            body, k = (b, 1) if a == GROUND else (a, 0)
            if body in parent:
                raise SystemExit(f"bench_tree: body {body} closes a loop of ideal joints")
            parent[body] = (j, k)
        else:
            raise SystemExit("bench_tree: ideal joints between two bodies are not handled by this prototype")
    keep, blocks, syms = [], [], []
    for body in model.body_names:
        s = model.coordinates(body)
        if body in parent:
            th = ca.SX.sym(f"theta_{body}")
            j, k = parent[body]
            ground_point, local = ca.DM(j.points[1 - k]), ca.DM(j.points[k])
            blocks.append(ca.vertcat(ground_point - rotation(th) @ local, th))
            syms.append(th)
            keep.append(s.start + 2)
        else:
            p = ca.SX.sym(f"pose_{body}", 3)
            blocks.append(p)
            syms.append(p)
            keep += [s.start, s.start + 1, s.start + 2]
    return ca.vertcat(*syms), ca.vertcat(*blocks), np.array(keep)


def tree_system(scene, system: System) -> tuple[System, np.ndarray]:
    """The held-controller System of `scene` in tree coordinates, and the indices of the full
    state's y that are the tree state's (for x0)."""
    eqs = rrr4.dynamics.builder.build_equations(scene)
    par = eqs.parametric
    model = rrr4.Model.of(scene.graph)
    nq, n, nc = eqs.nq, eqs.n_actuators, len(eqs.clearance_joints)
    p, g, keep = tree_map(model)
    npq = p.shape[0]
    J = ca.jacobian(g, p)
    pd = ca.SX.sym("pd", npq)
    q, qd = g, J @ pd
    jdot_pd = ca.jtimes(J @ pd, p, pd)
    t = ca.SX.sym("t")
    y = ca.SX.sym("y", 2 * npq + 3)
    z = ca.SX.sym("z", system.nz)
    u = ca.SX.sym("u", system.nu)
    sub_p, sub_pd = y[:npq], y[npq:2 * npq]
    dd0, inc = z[:nc], z[nc:2 * nc]
    params = z[3 * nc:3 * nc + len(eqs.parameters)]
    effort = u[2:2 + n]
    zeros = ca.SX.zeros(n)
    args = dict(q=q, qd=qd, effort=effort, theta_ref=zeros, theta_d_ref=zeros, theta_dd_ref=zeros, delta_dot0=dd0,
                in_contact=inc, t=t, parameters=params)
    Q = -par.residual(**args, qdd=ca.SX.zeros(nq), **{"lambda": ca.SX.zeros(eqs.n_constraints)})["dynamics"]
    acc = par.acceleration(**args)
    m = ca.DM(np.diag(model.mass_matrix()))
    Mt = J.T @ (m * J)
    pdd = ca.solve(Mt, J.T @ (Q - m * jdot_pd))
    ydot = ca.vertcat(pd, pdd, acc["power_in"], acc["power_damping"], acc["power_friction"])
    subs = [ca.vertcat(p, pd)], [ca.vertcat(sub_p, sub_pd)]
    ydot = ca.substitute([ydot], *subs)[0]
    ode = ca.Function("ode", [t, y, z, u], ca.cse([ydot]), ["t", "y", "z", "u"], ["y_dot"])
    dd0n, incn, loss = par.contact_update(q, qd, dd0, inc, params)
    zn = ca.vertcat(dd0n, incn, z[2 * nc:3 * nc] + loss, z[3 * nc:])
    disc = ca.Function("discrete", [t, y, z], ca.substitute([zn], *subs), ["t", "y", "z"], ["z_next"])
    # the controller: the full system's, on the full state rebuilt from the tree state
    ym, zm, uf = ca.MX.sym("y", y.shape[0]), ca.MX.sym("z", z.shape[0]), ca.MX.sym("u_frame", system.nu_frame)
    full = ca.Function("full_state", [y], ca.substitute([ca.vertcat(q, qd, y[2 * npq:])], *subs))
    control = ca.Function("control", [ym, zm, uf], [system.control(full(ym), zm, uf)], ["y", "z", "u_frame"], ["u"])
    return System(ode, disc, control, system.c_sources), keep, full


class Recorder:
    """An integrator that records what simulate hands it, then steps with the real one."""

    def __init__(self, method):
        self.method, self.args = method, None
        self.name, self.jit = method.name, method.jit

    def run(self, system, x0, u, h, spf, chunk=50, progress=False, every=1):
        self.args = (system, np.array(x0), np.array(u), h, spf, every)
        return self.method.run(system, x0, u, h, spf, every=every)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", nargs="?", default=str(ROOT / "problems" / "paper_circle.yaml"))
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--step", type=float, default=None)
    ap.add_argument("--no-preload", action="store_true", help="the scene's preload off (the journals rattle)")
    a = ap.parse_args()
    scene = rrr4.load_scene(a.scene)
    if a.no_preload:
        from dataclasses import replace
        act = scene.actuation
        scene = replace(scene, name=scene.name + " without preload",
                        actuation=replace(act, preload=replace(act.preload, method="none")))
    from rrr4.integrators import METHODS
    method = METHODS[scene.integrator.method].from_settings(scene.integrator, jit=True)
    rec = Recorder(method)
    kw = {} if a.step is None else {"step": a.step}
    rrr4.simulate(scene, integrator=rec, t_end=a.t_end, **kw)
    system, x0, u, h, spf, every = rec.args
    if system.control is None:
        raise SystemExit("bench_tree: the prototype needs a held controller (actuation.control_rate)")
    tree, keep, full = tree_system(scene, system)
    nq = (system.ny - 3) // 2
    ny = system.ny
    y0 = x0[1:1 + ny]
    x0_t = np.r_[x0[0], y0[keep], y0[nq + keep], y0[2 * nq:], x0[1 + ny:]]
    model = rrr4.Model.of(scene.graph)
    plat = model.coordinates(model.task)

    def run(sys_):
        t0 = time.perf_counter()
        r = method.run(sys_, x0 if sys_ is system else x0_t, u, h, spf, every=every)
        return time.perf_counter() - t0, r

    run(system), run(tree)  # compile both
    times = {"reference-point": [], "tree": []}
    stats = {}
    for _ in range(a.repeats):
        for name, s in (("reference-point", system), ("tree", tree)):
            dt, r = run(s)
            times[name].append(dt)
            stats[name] = {k: v for k, v in r.stats.items() if k.endswith("per_step") or k == "newton_failures"}
            if name == "reference-point":
                ref = r.states
            else:
                tr = r.states
    q_ref = ref[:, 1:1 + nq]
    q_tree = np.array(full.map(tr.shape[0])(tr[:, 1:1 + tree.ny].T)).T[:, :nq]
    diff = np.max(np.linalg.norm(q_ref[:, plat][:, :2] - q_tree[:, plat][:, :2], axis=1))
    med = {k: float(np.median(v)) for k, v in times.items()}
    cpu = next((ln.split(":", 1)[1].strip() for ln in Path("/proc/cpuinfo").read_text().splitlines()
                if ln.startswith("model name")), platform.machine()) if Path("/proc/cpuinfo").exists() else ""
    print(f"{scene.name}: {method.name} at h = {h:g} s over {a.t_end:g} s, held controller; {cpu}; "
          f"medians of {a.repeats}, interleaved in one process")
    for name, s in (("reference-point", system), ("tree", tree)):
        print(f"  {name:16s} nq = {(s.ny - 3) // 2}, ODE {s.ode.n_instructions()} SX instructions, "
              f"stepping {med[name]:.3f} s, {stats[name]}")
    print(f"  tree / reference-point stepping time: {med['tree'] / med['reference-point']:.2f}; largest "
          f"platform-position difference between the two motions {diff:.2e} m")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Readable summary of what a scene describes and what would be simulated."""

from __future__ import annotations

import math

import numpy as np

from .mechanism import Model
from .mechanism.workspace import path_kinematics
from .scene import Scene
from .trajectory import sample_path


def scene_summary(scene: Scene) -> str:
    model = Model.of(scene.graph)
    m = scene.mechanism
    lines = [f"scene {scene.name}: {scene.description}".rstrip(": "), ""]
    lines.append(f"bodies ({len(model.body_names)}, {model.nq} coordinates):")
    if m is not None:
        for c in m.chains:
            lines.append(f"  chain {c.name}: base ({c.base[0]:+.3f}, {c.base[1]:+.3f}) m, "
                         f"driving {c.driving.length:.3f} m / {c.driving.mass:.3f} kg, "
                         f"following {c.following.length:.3f} m / {c.following.mass:.3f} kg, "
                         f"working mode {'+' if c.working_mode > 0 else '-'}acos")
        lines.append(f"  platform: {m.platform.mass:.3f} kg, {m.platform.inertia:.4g} kg m^2")
    else:
        for b in scene.graph.bodies:
            pts = ", ".join(p for p, _ in b.points)
            lines.append(f"  {b.name}: {b.mass:.4g} kg, {b.inertia:.4g} kg m^2; points {pts or 'none'}")
    acts = [f"{a.name} on {a.joint}" for a in scene.graph.actuators]
    task = ("no task body" if model.task is None else f"task body {model.task}" if model.task_dof == 3
            else f"task point of {model.task} (2 DOF)")
    lines.append(f"actuators ({len(acts)}): {', '.join(acts) or 'none'}; {task} "
                 f"(degree of redundancy {model.redundancy})")
    for d in scene.graph.drivers:
        rev = scene.graph.joint(d.joint).type == "revolute"
        what = (f"{math.degrees(d.initial):g} deg at {d.speed * 30 / math.pi:g} rpm" if rev
                else f"{d.initial:g} m at {d.speed:g} m/s")
        lines.append(f"driver {d.name}: joint {d.joint} from {what}")
    lines.append("")
    ideal = [j for j in model.joint_names if j not in model.clearance_joints]
    lines.append(f"ideal joints ({len(ideal)}): {' '.join(ideal)}")
    cl = [scene.joint(j) for j in scene.clearance_joints]
    if cl:
        lines.append(f"clearance joints ({len(cl)}):")
        for j in cl:
            lines.append(f"  {j.name}: journal radius {j.journal_radius * 1e3:.3g} mm, radial clearance "
                         f"{j.radial_clearance * 1e6:.4g} um, {j.journal_material.name}/{j.bearing_material.name}")
    else:
        lines.append("clearance joints: none")
    lines.append("")
    lines.append("effects simulated:")
    e = scene.effects
    if cl:
        k = "from materials" if e.contact.stiffness is None else f"{e.contact.stiffness:.4g}"
        lines.append(f"  contact: {e.contact.law}, c_r = {e.contact.restitution:g}, "
                     f"exponent {e.contact.exponent:g}, stiffness {k}")
        if e.friction.law == "none":
            lines.append("  friction: none (no friction terms)")
        else:
            lines.append(f"  friction: {e.friction.law}, mu = {e.friction.coefficient:g}")
    else:
        lines.append("  contact: none (all joints ideal, no contact or friction terms)")
    g = e.gravity
    lines.append(f"  gravity: {'none' if g == (0.0, 0.0) else f'({g[0]:g}, {g[1]:g}) m/s^2'}")
    a = scene.actuation
    if a.mode == "torque":
        lines.append(f"  actuation: feed-forward + {a.preload.method} preload (f_min = {a.preload.min_force:g} N) "
                     f"+ PD (kp = {a.kp:g} N m/rad, kd = {a.kd:g} N m s/rad), "
                     f"|tau| <= {max(a.torque_limit):g} N m")
    elif a.mode == "free":
        lines.append("  actuation: free (zero actuator torque)")
    else:
        lines.append("  actuation: prescribed actuator angles (driving constraints)")
    lines.append("")
    lines += _graph_lines(scene)
    lines.append("")
    s = sample_path(scene.path)
    pk = path_kinematics(scene)
    if scene.graph.task is None:
        lines.append(f"path: none; the drivers set the motion for {scene.path.duration:g} s")
        integ = scene.integrator
        lines.append(f"integrator: {integ.method}, step {integ.step:g} s")
        return "\n".join(lines)
    lo, hi = s.pose.min(axis=0), s.pose.max(axis=0)
    speed = np.linalg.norm(s.pose_d[:, :2], axis=1).max()
    lines.append(f"path: {scene.path.type}, {scene.path.duration:g} s, {scene.path.time_law} time law, "
                 f"{len(s.t)} samples")
    turn = (f"theta_o in [{np.degrees(lo[2]):.2f}, {np.degrees(hi[2]):.2f}] deg" if model.task_dof == 3
            else f"task point of {model.task} (its angle is free)")
    lines.append(f"  x in [{lo[0] * 1e3:.2f}, {hi[0] * 1e3:.2f}] mm, y in [{lo[1] * 1e3:.2f}, {hi[1] * 1e3:.2f}] mm, "
                 f"{turn}; peak speed {speed:.4g} m/s")
    cond, t = pk.worst_condition
    lines.append(f"  worst Jacobian condition number {cond:.4g} at t = {t:.4g} s "
                 f"(allowed <= {scene.path.max_condition_number:g})")
    if pk.sin_transmission is not None:
        lines.append(f"  smallest transmission |sin| {np.abs(pk.sin_transmission).min():.3f} "
                     f"(allowed >= {scene.path.min_transmission:g})")
    integ = scene.integrator
    lines.append(f"integrator: {integ.method}, step {integ.step:g} s")
    return "\n".join(lines)


def _graph_lines(scene: Scene) -> list[str]:
    """Terms in the generated equations and the size of each CasADi graph."""
    from .dynamics.builder import build_equations, graph_size
    eqs = build_equations(scene)
    lines = [f"equations: {eqs.nq} coordinates, {eqs.n_constraints} constraint rows; terms: "
             + "; ".join(eqs.terms)]
    for f in (eqs.acceleration, eqs.residual, eqs.contact_update, eqs.energy):
        g = graph_size(f)
        lines.append(f"  graph {f.name()}: {g['instructions']} SX instructions, {g['nodes']} nodes")
    return lines

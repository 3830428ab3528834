"""The controller's feed-forward and the preload against the inverse dynamics with every
known load, by virtual work computed by hand (tests/random_mechanisms.py's Bodies), for a
graph (the five-bar, whose task is a point) and for the closed-form n-RRR, in Python and in
the generated C.

The reference at a path instant: for every task direction i, tau . d theta_i = -W_i, with W_i
the virtual work of inertia, gravity and the known force elements on the displacement of
every body along x_i (differences of the assembly), so J^T tau is fixed and only the null
space is free; a load's own share is -(F . dp_i + tz dphi_i).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from rrr4 import build
from rrr4.codegen import STEP_KERNELS, codegen, compile_library, load_library
from rrr4.control import reference_grid, tabulated
from rrr4.optimal import optimal_time_law
from rrr4.preload import solve_preload
from rrr4.scene import parse_scene

from .test_right_numbers import Case, path_case

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
LOAD = {"type": "load", "name": "gripper", "body": "distal_3", "point": [0.05, 0.01], "force": [1.5, -2.0],
        "torque": 0.2, "frame": "body"}
SPRING = {"type": "spring_damper", "name": "balancer", "bodies": ["ground", "distal_1"],
          "points": [[0.2, 0.3], [0.0, 0.0]], "stiffness": 20.0, "damping": 0.5, "free_length": 0.2, "preload": 0.5}


def _scene(name: str, forces=(), **actuation):
    data = yaml.safe_load((PROBLEMS / f"{name}.yaml").read_text())
    data["name"] = f"{name}_ff"
    data["forces"] = [dict(f) for f in forces]
    data["path"]["sample_rate"] = 100.0  # 101 references: enough instants, a quick table
    data["actuation"].update(actuation)
    return parse_scene(data, data["name"])


def _virtual_work_residual(problem, t, tau) -> float:
    """max_i |tau . d theta_i + W_i| / scale at the path instant t (see the module docstring)."""
    return _case_residual(path_case(problem, t), tau)


def _case_residual(case, tau) -> float:
    b = case.bodies
    _, qdd, _, _ = (v.ravel() for v in case.mech.motion(case.q0[None], case.v[None], case.a[None]))
    s, sd = b.element_coordinates(case.q0), case.rate(b.element_coordinates)
    out = 0.0
    for i in range(case.k):
        d_theta = case.task_derivative(b.actuator_coordinates, i)
        work = b.generalised_work(case.q0, case.task_derivative(lambda q: q, i), qdd, s, sd,
                                  case.task_derivative(b.element_coordinates, i), known_only=True)
        out = max(out, abs(tau @ d_theta + work) / (1 + np.abs(tau).max()) / (1 + np.abs(d_theta).max()))
    return out


INSTANTS = (0.13, 0.5, 0.77)


@pytest.mark.parametrize("preload", ["none", "qp"])
def test_graph_feed_forward_balances_every_known_load(preload):
    """The five-bar with a gripper load and a spring-damper, known: the tabulated feed-forward
    (and with qp, the preload's efforts) satisfy the virtual work with both; an unknown load
    changes nothing the controller commands."""
    problem = build(_scene("redundant_five_bar", [LOAD, SPRING], preload={"method": preload, "min_force": 10.0}))
    t = reference_grid(problem)
    refs = tabulated(problem, t)
    for s in INSTANTS:
        k = int(round(s * (len(t) - 1)))
        assert _virtual_work_residual(problem, t[k], refs.tau_ff[k]) < 2e-6, s
    if preload == "qp":
        sol = solve_preload(problem)
        for s in INSTANTS:
            k = int(np.argmin(np.abs(sol.t - s)))
            assert _virtual_work_residual(problem, sol.t[k], np.asarray(sol.tau)[k]) < 2e-6, s
    unknown = build(_scene("redundant_five_bar", [dict(LOAD, known=False), SPRING],
                           preload={"method": preload, "min_force": 10.0}))
    without = build(_scene("redundant_five_bar", [SPRING], preload={"method": preload, "min_force": 10.0}))
    np.testing.assert_allclose(tabulated(unknown, t).tau_ff, tabulated(without, t).tau_ff, rtol=0, atol=1e-12)


def test_nrrr_feed_forward_balances_springs_and_loads_off_the_platform():
    """The closed-form 4-RRR with a spring on a driving link and a load on a following link,
    both known: the closed form takes neither, so the references are tabulated with them,
    and the feed-forward and the preload satisfy the virtual work."""
    spring = dict(SPRING, bodies=["ground", "driving_1"], points=[[-0.3, 0.0], [0.05, 0.0]])
    load = dict(LOAD, body="following_2", point=[0.05, 0.0])
    problem = build(_scene("paper_circle", [spring, load]))
    assert not problem.closed_form or problem.element_forces is not None
    t = reference_grid(problem)
    refs = tabulated(problem, t)
    for s in INSTANTS:
        k = int(round(s * (len(t) - 1)))
        assert _virtual_work_residual(problem, t[k], refs.tau_ff[k]) < 2e-6, s
    # the same 4-RRR written as a graph balances them the same way
    graph = build(_scene("paper_circle_graph", [spring, load]))
    np.testing.assert_allclose(tabulated(graph, t).tau_ff, refs.tau_ff, rtol=0, atol=1e-7)


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
def test_known_load_moves_the_generated_c_feed_forward_by_its_generalised_force(tmp_path):
    """The five-bar without preload, with and without a known gripper load: the generated C
    step's feed-forward changes by exactly the load's generalised force (its virtual work on
    every task direction), with no part in the null space (the minimum-norm efforts)."""
    steps, problems = {}, {}
    for name, forces in (("plain", []), ("loaded", [LOAD])):
        scene = _scene("redundant_five_bar", forces, preload={"method": "none", "min_force": 0.0})
        problems[name] = build(scene)
        codegen(scene, tmp_path / name)
        steps[name] = load_library(compile_library(tmp_path / name, tmp_path / f"{name}.so"),
                                   STEP_KERNELS)["controller_step"]
    problem = problems["loaded"]
    t = reference_grid(problem)
    n = problem.model.n_actuators
    ff = {k: np.array(f.map(len(t))(t[None, :], np.zeros((n, len(t))), np.zeros((n, len(t))))[1]).T
          for k, f in steps.items()}
    d_tau = ff["loaded"] - ff["plain"]
    assert np.abs(d_tau).max() > 0.1  # the load matters
    np.testing.assert_allclose(ff["loaded"], tabulated(problem, t).tau_ff, rtol=0, atol=1e-12)
    fam = problem.effort_family(*(np.array(v) for v in _path_rows(problem, t)))
    for s in INSTANTS:
        k = int(round(s * (len(t) - 1)))
        case = path_case(problem, t[k])
        body = case.bodies
        for i in range(case.k):
            d_theta = case.task_derivative(body.actuator_coordinates, i)
            dq = case.task_derivative(lambda q: q, i)
            j = body.names.index(LOAD["body"])
            th = case.q0[3 * j + 2]
            c, s_ = np.cos(th), np.sin(th)
            force = np.array([[c, -s_], [s_, c]]) @ LOAD["force"]
            arm = np.array([[c, -s_], [s_, c]]) @ LOAD["point"]
            dp = dq[3 * j:3 * j + 2] + dq[3 * j + 2] * np.array([-arm[1], arm[0]])
            work = force @ dp + LOAD["torque"] * dq[3 * j + 2]
            assert d_tau[k] @ d_theta == pytest.approx(-work, abs=1e-7 * (1 + abs(work))), (s, i)
        assert abs(d_tau[k] @ fam.tau_n[k, :, 0]) < 1e-9  # no null-space share


def _path_rows(problem, t):
    from rrr4.control import path_rows

    rows = path_rows(problem.path, t)
    return rows[:, 0:3], rows[:, 3:6], rows[:, 6:9]


def test_time_optimal_law_on_a_graph_is_the_inverse_dynamics_of_its_motion():
    """The five-bar's time-optimal law with a known load and spring (the contact condition on):
    at grid points along it, its efforts satisfy the virtual work of its own motion."""
    problem = build(_scene("redundant_five_bar", [LOAD, dict(SPRING, damping=0.0)]))
    law = optimal_time_law(problem, points=60)
    assert law.statistics["success"] and law.contact
    k = problem.mechanism.n_task
    for i in (7, 30, 52):
        pose, v, a = law.pose[i, :k], law.pose_d[i, :k], law.pose_dd[i, :k]
        case = Case(problem, lambda t, p=pose, v=v, a=a: p + v * t + a * t**2 / 2, v, a,
                    problem.mechanism.assemble(pose))
        assert _case_residual(case, law.efforts[i]) < 2e-6, i

"""Tree coordinates (rrr4.mechanism.tree, integrator.coordinates): the same motion as
reference-point coordinates, with fewer coordinates and no constraint for the tree's joints."""

import dataclasses

import casadi as ca
import numpy as np
import pytest

from rrr4 import Model, SceneError, build, load_scene, simulate
from rrr4.mechanism.tree import tree_map
from rrr4.scene import parse_scene

from .conftest import ROOT


def _coordinates(scene, c):
    return dataclasses.replace(scene, integrator=dataclasses.replace(scene.integrator, coordinates=c))


@pytest.mark.parametrize("name, n_p, closures", [
    ("paper_circle", 19, ()),                          # the 4 driving links keep their angles
    ("flores_slider_crank", 3, ()),                    # crank angle, rod angle, slide
    ("ideal_circle", 9, ("C2", "C3", "C4")),           # every joint ideal: 9 angles, three loops close
])
def test_tree_map_counts_and_round_trip(name, n_p, closures):
    """The tree's size and loop closures; on an assembled state q -> p -> q is the identity."""
    scene = load_scene(ROOT / "problems" / f"{name}.yaml")
    model = Model.of(scene.graph)
    tree = tree_map(model)
    assert tree.p.shape[0] == n_p and tree.closures == closures
    assert len(tree.tree_joints) + len(closures) == len(model.constrained_joints)
    q0 = simulate(_coordinates(scene, "reference-point"), t_end=1e-3, jit=False).q[0]
    p0 = ca.Function("p", [tree.q_symbols], [tree.coordinate])(q0)
    np.testing.assert_allclose(np.array(ca.Function("q", [tree.p], [tree.q])(p0)).ravel(), q0, atol=1e-14)


@pytest.mark.parametrize("name, t_end, step", [
    ("paper_circle", 0.01, 1e-6),          # 8 clearance joints, friction, preload, held controller
    ("flores_slider_crank", 0.004, 1e-7),  # a driver and a prismatic joint, impacts (before the rattling diverges)
    ("ideal_circle", 0.02, 1e-5),          # loop closures kept as Baumgarte-stabilised constraints
])
def test_tree_coordinates_step_the_same_motion(name, t_end, step):
    """RK4 at a fine step in both coordinates: the same motion to 1e-9 m (measured 1e-12 or
    less), the same efforts and driver efforts, and the same energy audit; the tree's ODE is
    smaller."""
    scene = load_scene(ROOT / "problems" / f"{name}.yaml")
    a, b = (simulate(_coordinates(scene, c), integrator="rk4", step=step, t_end=t_end, jit=False)
            for c in ("reference-point", "tree"))
    assert (a.stats["coordinates"], b.stats["coordinates"]) == ("reference-point", "tree")
    assert np.max(np.abs(a.q - b.q)) < 1e-9 and np.max(np.abs(a.qd - b.qd)) < 1e-6
    np.testing.assert_allclose(b.tau, a.tau, atol=1e-6)
    np.testing.assert_allclose(b.driver_effort, a.driver_effort, rtol=1e-6, atol=1e-6)
    assert b.energy_audit_residual < 1e-6 and a.contact_loss_events == b.contact_loss_events
    assert b.stats["graph"]["ode"]["instructions"] < a.stats["graph"]["ode"]["instructions"]


def test_tree_is_the_default_where_a_tree_exists_and_bad_values_are_one_line(paper_scene):
    eqs = build(paper_scene).equations()
    assert eqs.tree_acceleration is not None and eqs.tree_acceleration.size1_in(0) == 19
    assert paper_scene.integrator.coordinates == "auto"
    assert simulate(paper_scene, t_end=2e-4, jit=False).stats["coordinates"] == "tree"
    data = {"integrator": {"coordinates": "minimal"}}
    with pytest.raises(SceneError, match=r"integrator.coordinates: unknown value 'minimal' .*auto, tree, "
                                         r"reference-point"):
        parse_scene({**_yaml(ROOT / "problems" / "paper_circle.yaml"), **data})


def _yaml(path):
    import yaml
    return yaml.safe_load(path.read_text())

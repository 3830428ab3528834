"""Identification by the staged strategy (seated, then dynamic over the whole record), method
'dynamic' with link lengths (the equations' geometry inputs), and the frame inputs' layout
(rrr4.simulation.input_layout) that the run and identification's shooting both write.

The perturbed reference plant: every clearance between 70 and 130 um, friction 0.15, the
contact stiffness 1e10 N/m^1.5 and the second chain's driving link 150 um longer, run under the
nominal controller with noise 1 um, 1e-5 rad and 1 % of each effort's RMS."""

from __future__ import annotations

import numpy as np
import pytest

import rrr4
from rrr4.control import path_rows
from rrr4.identify import Measurements, identify, measurements_from_simulation, resolve_parameters
from rrr4.identify.dynamic import DynamicData
from rrr4.simulation.system import loop_of, system_of
from rrr4.studies.study import arm_scene

from .conftest import PAPER

CLEARANCES = dict(zip([f"joints.per_joint.{j}.radial_clearance" for j in ("B1", "B2", "B3", "B4", "C1", "C2", "C3",
                                                                          "C4")],
                      [125e-6, 78e-6, 112e-6, 71e-6, 86e-6, 129e-6, 93e-6, 118e-6], strict=True))
LINK = "mechanism.chains[1].driving_link.length"
TRUTH = {**CLEARANCES, "effects.friction.coefficient": 0.15, "effects.contact.stiffness": 1.0e10, LINK: 0.25 + 150e-6}


def _measured(truth: dict, t_end: float, seed: int = 1):
    """(nominal scene, noisy measurements of the plant `truth` under the nominal controller, the
    noise levels, the plant scene)."""
    nominal = rrr4.load_scene(PAPER)
    plant = nominal.with_values(truth, name="plant")
    clean = measurements_from_simulation(rrr4.simulate(plant, t_end=t_end, model=nominal, output_rate=1000))
    noise = {"x_m": 1e-6, "y_m": 1e-6, "theta_rad": 1e-5,
             **{c: 1e-5 for c in clean.columns if c.startswith("theta_A")},
             **{c: 0.01 * float(np.sqrt(np.mean(v ** 2))) for c, v in clean.columns.items() if c.startswith("tau_")}}
    rng = np.random.default_rng(seed)
    cols = {c: clean.columns[c] + s * rng.standard_normal(len(clean.t)) for c, s in noise.items()}
    return nominal, Measurements(clean.t, cols, {}, "noisy plant"), noise, plant


def test_frame_inputs_have_one_layout_that_the_system_reads():
    """The held controller of the reference scene: the Loop's layout is as wide as the System's
    controller takes, the right-hand side's input holds [t_a, t_b, efforts], and the rows the
    layout writes carry the path at each frame's start (the circle starts at the home pose at
    rest: quintic time law)."""
    problem = rrr4.build(rrr4.load_scene(PAPER))
    eqs = problem.equations()
    loop = loop_of(problem, eqs, "python", "exact", None)
    system = system_of(problem, eqs, loop, None, False)
    lay = loop.inputs
    assert lay.kind == "held" and lay.step == (3, 3, 3)
    assert system.control.size1_in(2) == lay.width == 11 and system.ode.size1_in(3) == lay.ode_width == 6
    t = np.array([0.0, 1e-4, 0.5, 0.5001])
    step = [v.T for v in np.split(path_rows(problem.path, t[:-1])[:, :9], 3, axis=1)]
    rows = lay.rows(t, step=step)
    assert rows.shape == (3, lay.width)
    np.testing.assert_array_equal(rows[:, 0], t[:-1])
    np.testing.assert_array_equal(rows[:, 1], t[1:])
    pose, rate = rows[0, lay.step_inputs()[0]], rows[0, lay.step_inputs()[1]]
    assert np.allclose(pose, 0.0, atol=1e-15) and np.allclose(rate, 0.0, atol=1e-15)
    # half way round the 20 mm circle about (-0.02, 0): the pose is at (-0.04, 0)
    assert rows[2, lay.step_inputs()[0]] == pytest.approx([-0.04, 0.0, 0.0], abs=1e-9)


def test_link_length_sensitivities_agree_with_central_differences():
    """Method 'dynamic' with a driving link's length (the equations' geometry inputs) and a
    clearance: its forward sensitivities over 10 ms against central differences of whole
    runs (the reference), at two steps."""
    nominal, m, noise, _ = _measured(TRUTH, 0.01)
    problem = rrr4.build(nominal)
    data = DynamicData(problem, m, resolve_parameters(problem, [LINK, "joints.per_joint.B2.radial_clearance"],
                                                      nominal.data), nominal)
    assert data.inputs == "geometry"
    p = np.array([q.nominal for q in data.params])
    J = data.residuals(p, noise)["J"]
    assert np.all(np.linalg.norm(J, axis=0) > 0)
    for step in (1e-2, 1e-3):
        J_cd = data.central_differences(p, noise, step=step)
        assert np.all(np.linalg.norm(J - J_cd, axis=0) / np.linalg.norm(J_cd, axis=0) < 1e-3)


def test_staged_finds_a_link_length_and_the_clearance_on_a_short_record():
    """The fast version of the full-record test below: 10 ms, the clearance of all eight
    joints (120 um) and the second driving link (+150 um). Stage 1 (seated) runs and says what it
    found, stage 2 (dynamic) ends within 3 standard errors and 5 um of both (measured: 119.85 +-
    0.22 um, 250.150 mm +- 5.6 um)."""
    truth = {"joints.radial_clearance": 120e-6, LINK: 0.25 + 150e-6}
    nominal, m, noise, _ = _measured(truth, 0.01, seed=4)
    res = identify(nominal, m, list(truth), noise=noise)
    assert res.method == "staged"
    stages = res.fit["stages"]
    assert [s["method"] for s in stages] == ["seated", "dynamic"] and "skipped" not in stages[0]
    assert "moving on" in stages[0]["said"] and "stage 2, dynamic" in res.table()
    for key, value in truth.items():
        i = res.keys.index(key)
        assert abs(res.estimate[i] - value) < min(3 * res.standard_error[i], 5e-6), (key, res.estimate[i], value)


@pytest.mark.slow
def test_staged_recovers_the_perturbed_reference_plant_from_one_second(monkeypatch):
    """Issue 46's case: 1 s at 1 kHz, every clearance, friction, stiffness and the second driving
    link. Each clearance within 5 um, friction within 0.02, the link within 5 um; the
    compensated controller with the identified model on the plant within 25 % (or 0.5 um) of the
    platform error with the true model. Compiled stepping (as a user runs it); the numbers are
    in docs/identification.md (benchmarks/bench_identify_staged.py)."""
    monkeypatch.setenv("RRR4_JIT", "1")
    nominal, m, noise, plant = _measured(TRUTH, 1.0)
    res = identify(nominal, m, list(TRUTH), noise=noise)
    err = {k: res.value(k) - v for k, v in TRUTH.items()}
    assert all(abs(err[k]) < 5e-6 for k in CLEARANCES), err
    assert abs(err["effects.friction.coefficient"]) < 0.02 and abs(err[LINK]) < 5e-6, err
    arm = "with_preload_compensated"

    def error(model):
        kw = {} if model is None else {"model": arm_scene(rrr4.build(model), arm)}
        sim = rrr4.simulate(arm_scene(rrr4.build(plant), arm), **kw)
        return float(np.sqrt(np.mean(sim.platform_error ** 2)))

    identified, true = error(res.identified), error(None)
    assert identified <= max(1.25 * true, true + 0.5e-6), (identified, true)


def test_the_sensitivity_frames_generated_c_does_not_grow_with_its_directions():
    """Issue 44: the frame with nine parameters and windows was 28 MB of C (its forward
    derivative unrolled: each direction a copy of the frame's derivative, about 0.8 MB). The
    frames of 1 and of 40 directions share the step and system (built once per problem
    structure); their derivatives call the one-direction derivatives of the frame's leaves once
    per direction, so each direction adds a few kB of calls (measured 1.49 MB of C for 1
    direction, 1.85 MB for 40: 9 kB, 0.6 %, per direction)."""
    import casadi as ca

    from rrr4.identify.dynamic import sensitivity_frame

    problem = rrr4.build(rrr4.load_scene(PAPER))

    def c_size(f):
        cg = ca.CodeGenerator("f.c", {"with_header": False})
        cg.add(f)
        return len(cg.dump())

    one = sensitivity_frame(problem, 1, 1e-3, jit=False)
    forty = sensitivity_frame(problem, 40, 1e-3, jit=False)
    assert one[1] is forty[1] and one[0].size2_in(1) == 1 and forty[0].size2_in(1) == 40
    small, large = c_size(one[0]), c_size(forty[0])
    assert 0 <= large - small < 39 * 0.02 * small, (small, large)

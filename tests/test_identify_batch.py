"""Runs without sensitivities rolled together (rrr4.identify.dynamic.DynamicData.run_batch: one
call of the compiled frame mapped over the runs in threads per chunk of frames) against the same
runs one at a time (DynamicData.run): the same numbers, bit for bit, and so the same check of
the sensitivities (central differences of whole runs) as its loop of single runs."""

from __future__ import annotations

import numpy as np
import pytest

import rrr4
from rrr4.identify import dynamic as dynamic_module
from rrr4.identify import measurements_from_simulation, resolve_parameters
from rrr4.identify.dynamic import DynamicData

from .conftest import PAPER

CLEARANCE, FRICTION = "joints.radial_clearance", "effects.friction.coefficient"
LINK = "mechanism.chains[1].driving_link.length"


@pytest.fixture(scope="module")
def data():
    """A 20 ms run of the reference scene (journals seated: each candidate's start is its own) with a
    clearance, friction and a link length (the geometry inputs) as parameters."""
    nominal = rrr4.load_scene(PAPER)
    plant = nominal.with_values({CLEARANCE: 1.2e-4, FRICTION: 0.15}, name="plant")
    m = measurements_from_simulation(rrr4.simulate(plant, t_end=0.02, model=nominal, output_rate=1000))
    problem = rrr4.build(nominal)
    return DynamicData(problem, m, resolve_parameters(problem, [CLEARANCE, FRICTION, LINK], nominal.data), nominal)


def _points(data):
    p = np.array([q.nominal for q in data.params])
    return np.array([p, data.shifted(p, 0), data.shifted(p, 1, -0.3), data.shifted(p, 2, 0.5), p])  # p twice


def test_a_batch_of_runs_is_the_runs_one_at_a_time_bit_for_bit(data, monkeypatch):
    monkeypatch.setattr(dynamic_module, "CHUNK", 6)  # 21 frames: three chunks of 6 and a short one
    P = _points(data)
    single = []
    for p in P:
        data._cache.clear()
        single.append(data.run(p, False)[0])
    data._cache.clear()
    before = data.runs
    batch = data.run_batch(P)
    assert data.runs - before == len(P) - 1  # the repeated point once
    assert len(batch) == len(P) and batch[0].shape == (data.n_frames, len(data.outputs))
    for one, together in zip(single, batch, strict=True):
        np.testing.assert_array_equal(together, one)
    assert not np.array_equal(batch[1], batch[0])  # the points' runs differ: the rows are not mixed up
    sigma = data.initial_noise()
    r = data.residuals_batch(P[1:3], sigma)
    np.testing.assert_array_equal(r[1], data.residuals(P[2], sigma, jacobian=False)["r"])


def test_the_check_from_batched_runs_is_the_loop_of_single_runs(data):
    p = _points(data)[0]
    sigma = data.initial_noise()
    data._cache.clear()
    J_cd = data.central_differences(p, sigma)
    cols = []
    for i, q in enumerate(data.params):  # the check as it was: two runs per parameter, one at a time
        up, down = data.shifted(p, i), np.array(p)
        down[i] = q.value(q.coordinate(p[i]) - dynamic_module.FD_STEP)
        r_up, r_down = (data.residuals(v, sigma, jacobian=False)["r"] for v in (up, down))
        cols.append((r_up - r_down) / (up[i] - down[i]))
    np.testing.assert_array_equal(J_cd, np.column_stack(cols))
    assert np.linalg.norm(J_cd[:, 0]) > 0 and np.linalg.norm(J_cd[:, 2]) > 0  # the clearance and the link move it

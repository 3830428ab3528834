"""A seated start: journals rest on their bearing walls under the initial load."""

import dataclasses

import numpy as np
import pytest

import rrr4
from rrr4.mechanism import Mechanism


@pytest.fixture(scope="module")
def preload(paper_scene):
    return rrr4.solve_preload(paper_scene, "qp")


def _with_journals(scene, journals):
    return dataclasses.replace(scene, initial=dataclasses.replace(scene.initial, journals=journals))


def test_seated_coordinates_open_each_joint_by_its_eccentricity(paper_scene):
    mech = Mechanism.from_scene(paper_scene)
    rng = np.random.default_rng(3)
    pose = np.array([0.01, -0.02, 0.05])
    ecc = rng.uniform(-1e-4, 1e-4, size=(8, 2))
    q = mech.seated_coordinates(pose, ecc)
    gap = np.array(mech.joint_gap_function(q))  # (2, 12): A1..A4, B1..B4, C1..C4
    assert np.max(np.abs(gap[:, :4])) < 1e-15          # ground pins stay closed
    assert np.max(np.abs(gap[:, 4:].T - ecc)) < 1e-15  # each passive joint opens by its eccentricity
    assert np.max(np.abs(q[-3:] - pose)) == 0.0        # the platform stays where it was put


def test_seated_start_begins_at_the_ideal_reactions(paper_scene, preload):
    """At t = 0 the contact force of every seated joint equals the ideal reaction of the
    preloaded torque program (direction and magnitude): the journal starts in equilibrium."""
    sim = rrr4.simulate(_with_journals(paper_scene, "seated"), "rk4", t_end=1e-3, step=1e-5, preload=preload,
                        output_rate=1e4)
    r0 = preload.reactions[0]
    assert sim.clearance_joints == tuple(j.name for j in paper_scene.joints)
    assert np.max(np.abs(sim.contact_force[0] - r0)) < 1e-6 * np.abs(r0).max()
    assert np.all(sim.penetration[0] > 0)


def test_seated_preloaded_start_loses_no_contact_where_centred_start_rattles(paper_scene, preload):
    runs = {j: rrr4.simulate(_with_journals(paper_scene, j), "rk4", t_end=0.03, step=1e-5, preload=preload,
                             output_rate=2e4)
            for j in ("centred", "seated")}
    assert sum(runs["seated"].contact_loss_events.values()) == 0
    assert runs["seated"].normal_force.min() > 0.5 * paper_scene.actuation.preload.min_force
    assert sum(runs["centred"].contact_loss_events.values()) > 0  # the impacts the seated start avoids

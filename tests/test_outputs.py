"""What a simulation keeps: its outputs at their rate (memory that grows with nothing else),
and the extremes of the motion at every integrator step, whatever the output rate."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np

import rrr4
from rrr4.results.metrics import arm_metrics, scalar_metrics

from .conftest import ROOT

SLIDER = ROOT / "problems" / "flores_slider_crank.yaml"
FREE = ROOT / "problems" / "conservative_free.yaml"


def test_memory_beyond_the_outputs_does_not_grow_with_the_duration():
    # benchmarks/bench_memory.py in fresh processes (peak RSS: tracemalloc does not see what
    # CasADi allocates, where most of the growth was): 10 000 and 30 000 outputs, one per step.
    # What a run needs above its output arrays (copies of the states, whole-run temporaries,
    # what a long compiled call builds) must not grow with the run; it grew by 3.3 times the
    # outputs' growth before the outputs were written as the run went
    out = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_memory.py"), str(FREE), "--short", "0.01",
                          "--long", "0.03", "--output-rate", "1e6", "--json"], capture_output=True, text=True,
                         check=True, env={**os.environ, "PYTHONPATH": os.pathsep.join(
                             [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])})
    short, long = json.loads(out.stdout.strip().splitlines()[-1])
    grown_outputs = long["outputs"] - short["outputs"]
    grown_rest = (long["peak"] - long["outputs"]) - (short["peak"] - short["outputs"])
    assert grown_outputs > 20e6
    assert grown_rest < 0.25 * grown_outputs, (grown_rest, grown_outputs)


def test_peak_contact_force_does_not_depend_on_the_output_rate():
    # the slider-crank's first milliseconds: the journal flies and hits its bearing; a 1 kHz output
    # misses the impacts' peaks, the extremes tracked at every step do not
    scene = rrr4.load_scene(SLIDER)
    fine = rrr4.simulate(scene, t_end=0.004, output_rate=1e6)
    coarse = rrr4.simulate(scene, t_end=0.004, output_rate=1e3)
    assert fine.stats["steps"] == coarse.stats["steps"] and len(fine.t) == 1000 * (len(coarse.t) - 1) + 1
    sampled = float(coarse.normal_force.max())
    a, b = scalar_metrics(fine), scalar_metrics(coarse)
    for key in ("peak_contact_force_N", "min_contact_force_N"):
        assert np.isclose(a[key], b[key], rtol=1e-9, atol=1e-9), (key, a[key], b[key])
    assert b["peak_contact_force_N"] > 1.5 * sampled  # what the samples alone reported
    ma, mb = arm_metrics(fine, 0.0), arm_metrics(coarse, 0.0)
    assert np.isclose(ma["max_penetration_m"], mb["max_penetration_m"], rtol=1e-9)
    for j in fine.clearance_joints:  # (an ideal joint's reaction is taken over the samples)
        assert np.isclose(ma["peak_contact_force_N"][j], mb["peak_contact_force_N"][j], rtol=1e-9)


def test_extremes_are_those_of_the_samples_when_every_step_is_an_output():
    scene = rrr4.load_scene(SLIDER)
    sim = rrr4.simulate(scene, t_end=0.002, output_rate=1e6)
    ext = sim.extremes
    # refined sub-steps across contact events are steps too: the tracked extremes include them
    assert np.all(ext["normal_force_max"] >= sim.normal_force.max(axis=0) * (1 - 1e-9))
    assert np.all(ext["normal_force_min"] <= sim.normal_force.min(axis=0) + 1e-9)
    assert np.all(ext["penetration_max"] >= sim.penetration.max(axis=0) - 1e-15)
    assert np.allclose(ext["normal_force_max"], sim.normal_force.max(axis=0), rtol=0.2)


def test_torque_peak_is_tracked_between_outputs(paper_scene):
    # the reference scene's sampled controller holds a new torque every 1e-4 s: a 100 Hz output
    # sees one control period in a hundred, the tracked peak sees them all
    coarse = rrr4.simulate(paper_scene, t_end=0.05, output_rate=100)
    fine = rrr4.simulate(paper_scene, t_end=0.05, output_rate=1e4)
    a, b = fine.extremes["tau_abs_max"], coarse.extremes["tau_abs_max"]
    assert np.allclose(a, b, rtol=1e-12, atol=0)
    assert np.allclose(a, np.abs(fine.tau[:-1]).max(axis=0), rtol=1e-9)

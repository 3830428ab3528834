"""Bad input, round three (issue 41): the new commands' files and arguments, and two wrong
answers that were given with confidence. One test (or property) per class; each fails
without its fix."""

import numpy as np
import pytest

import rrr4
from rrr4 import Mechanism
from rrr4.cli import main
from rrr4.errors import InfeasibleError
from rrr4.identify import identify, measurements_from_simulation
from rrr4.optimal import optimal_motion
from rrr4.optimal.point_to_point import MIN_SAMPLES_PER_INTERVAL
from rrr4.studies.study import arm_scene
from tests.conftest import PAPER

# ------------------------------------------------------------------ optimize: margins between nodes


def test_pure_turn_through_a_parallel_singularity_is_refused_not_reported_as_safe(paper_scene):
    """The straight turn to theta = -1 rad crosses a parallel singularity near -0.63 rad between
    two nodes; held at the nodes only, the margin looked like 99. Now refused, naming the value."""
    with pytest.raises(InfeasibleError, match=r"condition number of J of [0-9.e+]+ at t = .* between the nodes"):
        optimal_motion(paper_scene, [0.0, 0.0, -1.0], nodes=10)


def test_reported_margins_are_the_extremes_along_the_whole_motion(paper_scene):
    """The condition number and transmission the summary reports are those of the returned
    motion everywhere: compared with the mechanism's own Jacobian (its public method, per pose)
    on a grid 3x finer than the check's, between the nodes of the constant-acceleration motion."""
    m = optimal_motion(paper_scene, [0.02, 0.01, 0.3], nodes=8)
    s = m.summary()
    mech = Mechanism.from_scene(paper_scene)
    h = m.duration / (len(m.t) - 1)
    u = np.linspace(0.0, h, 3 * MIN_SAMPLES_PER_INTERVAL + 1)[:-1]
    poses = [m.pose[k] + v * m.pose_d[k] + 0.5 * v**2 * m.pose_dd[k] for k in range(len(m.t) - 1) for v in u]
    cond = np.array([np.linalg.cond(mech.jacobian(p)) for p in poses])
    assert s["max_condition_number"] >= s["max_condition_number_at_nodes"]
    assert s["max_condition_number"] == pytest.approx(cond.max(), rel=1e-3)
    assert s["max_condition_number"] <= paper_scene.path.max_condition_number
    assert s["margins_checked_at"] >= MIN_SAMPLES_PER_INTERVAL * (len(m.t) - 1)


# ------------------------------------------------------------------ identify: a start-up record


def test_friction_from_a_50_ms_start_up_record_is_refused_not_reported(paper_scene, tmp_path, capsys):
    """The reference scene's own 50 ms run (true friction 0.1): the journals do not yet slide
    steadily, the seated fit gave 0.0032 +- 0.0001 'identifiable' and wrote it. Now one line
    naming the friction coefficient, exit 2, no identified.yaml; the clearance alone (which the
    record does determine) is still identified, and right."""
    sim = rrr4.simulate(arm_scene(rrr4.build(paper_scene), "with_preload"), t_end=0.05)
    csv = measurements_from_simulation(sim).write_csv(tmp_path / "timeseries.csv", prefix="with_preload_")
    out = tmp_path / "ident"
    assert main(["identify", str(PAPER), str(csv), "--arm", "with_preload", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "effects.friction.coefficient: the seated model does not explain" in err[0]
    assert not out.exists()
    res = identify(paper_scene, csv, ["joints.radial_clearance"], arm="with_preload")
    assert res.value("joints.radial_clearance") == pytest.approx(1e-4, rel=0.01)  # the scene's 0.1 mm

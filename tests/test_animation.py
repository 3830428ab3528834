"""The animation of a study: saved motion, frame count, drawn geometry, bad result directories."""

import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

import rrr4
from rrr4 import Model, Rrr4Error
from rrr4.results import write_results
from rrr4.results.animation import MOTION, build, load_motion, render
from rrr4.studies.study import run_study
from tests.conftest import PAPER, ROOT


@pytest.fixture(scope="module")
def paper_result(tmp_path_factory):
    out = tmp_path_factory.mktemp("anim") / "paper"
    study = run_study(rrr4.load_scene(PAPER), t_end=0.01)
    _, files = write_results(study, out)
    assert {"motion.npz", "motion.gif"} <= set(files)
    return out, study


def test_frame_count_matches_the_settings(paper_result, tmp_path):
    out, _ = paper_result
    data, scene = load_motion(out)
    assert len(data["t"]) == 11                              # 10 ms at the path's 1 kHz
    gif = render(out, tmp_path / "six.gif", frames=6, progress=False)
    assert Image.open(gif).n_frames == 6
    assert Image.open(out / "motion.gif").n_frames == 11     # default: every sample up to 60


def test_drawn_joint_positions_equal_the_simulated_ones(paper_result):
    """In a chosen frame, the joint markers sit where the simulation put the joints (CasADi
    joint equations of the model at the simulated q), for both arms."""
    out, study = paper_result
    data, scene = load_motion(out)
    fig, update, n = build(data, rrr4.build(scene), frames=11)
    model = Model.of(scene.graph)
    k = 7
    update(k)
    for ax, arm in zip(fig.axes, data["arms"], strict=False):
        drawn = next(line for line in ax.lines if line.get_label() == "joints")
        xy = np.c_[drawn.get_xdata(), drawn.get_ydata()]
        sim = study.arms[str(arm)].simulation
        row = int(np.argmin(np.abs(sim.t - data["t"][k])))
        want = np.array([np.array(model.joint_points(sim.q[row], j)[0]).ravel() for j in scene.graph.joints])
        np.testing.assert_allclose(xy, want, atol=1e-12)
    assert f"t = {data['t'][k]:.3f} s" in fig._suptitle.get_text()


def test_animation_of_a_driven_graph_scene(tmp_path):
    study = run_study(rrr4.load_scene(ROOT / "problems" / "flores_slider_crank.yaml"), t_end=0.001, step=2e-6)
    _, files = write_results(study, tmp_path / "slider")
    assert "motion.gif" in files
    data, _ = load_motion(tmp_path / "slider")
    assert list(data["arms"]) == ["with_clearance", "ideal"] and data["eccentricity_with_clearance"].shape[1:] == (1, 2)


def test_animate_refuses_a_directory_that_is_not_a_result_or_has_no_motion(paper_result, tmp_path):
    with pytest.raises(Rrr4Error, match="is not an rrr4 result directory"):
        load_motion(tmp_path)
    out, _ = paper_result
    bare = tmp_path / "bare"
    bare.mkdir()
    (bare / "summary.json").write_text((out / "summary.json").read_text())
    with pytest.raises(Rrr4Error, match=f"holds no motion data \\({MOTION}\\)"):
        load_motion(bare)
    r = subprocess.run([sys.executable, "-m", "rrr4.cli", "animate", str(bare)], capture_output=True, text=True)
    assert r.returncode != 0 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("damage", ["missing q", "columns", "all nan", "empty", "arm name", "other scene", "not text"])
def test_a_saved_result_is_checked_against_what_its_writer_writes(tmp_path, damage, capsys):
    """rrr4 animate on a motion.npz that loads but is wrong ends in one line naming the entry,
    and writes nothing."""
    import shutil

    import numpy as np

    from rrr4.cli import main
    src = ROOT / "results" / "paper_circle"
    d = tmp_path / "r"
    d.mkdir()
    shutil.copy(src / "summary.json", d)
    with np.load(src / "motion.npz", allow_pickle=False) as z:
        data = {k: z[k] for k in z.files}
    arm = str(data["arms"][0])
    if damage == "missing q":
        del data[f"q_{arm}"]
    elif damage == "columns":
        data[f"q_{arm}"] = data[f"q_{arm}"][:, :-1]
    elif damage == "all nan":
        data[f"normal_force_{arm}"] = np.full_like(data[f"normal_force_{arm}"], np.nan)
    elif damage == "empty":
        data = {k: (v[:0] if v.ndim and k not in ("arms",) and not k.startswith("clearance_joints") else v)
                for k, v in data.items()}
    elif damage == "arm name":
        data["arms"] = np.array(["../../etc"] + [str(a) for a in data["arms"][1:]])
    elif damage == "other scene":
        data["scene_yaml"] = np.array((ROOT / "problems" / "flores_slider_crank.yaml").read_text())
    else:
        data["scene_yaml"] = np.array("mechanism: !!python/object:os.system {}")
    np.savez_compressed(d / "motion.npz", **data)
    assert main(["animate", str(d)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "motion.npz" in err, err
    assert sorted(p.name for p in d.iterdir()) == ["motion.npz", "summary.json"]


def test_any_damage_to_a_saved_result_loads_or_ends_in_one_line(paper_result, tmp_path_factory):
    """Property (the bad-scene property, for saved results): a real motion.npz as the study
    writes it, damaged in drawn ways (arrays dropped, reshaped, of another dtype, empty, with
    NaN or inf, odd arm or joint names, another or no scene text), either loads, and then
    draws, or ends in one Rrr4Error line; never another exception."""
    import shutil

    import matplotlib.pyplot as plt
    from hypothesis import HealthCheck, example, given, settings
    from hypothesis import strategies as st
    from hypothesis.extra import numpy as hnp

    out, _ = paper_result
    with np.load(out / MOTION, allow_pickle=False) as z:
        base = {k: z[k] for k in z.files}
    d = tmp_path_factory.mktemp("damaged")
    shutil.copy(out / "summary.json", d)
    keys = sorted(base) + ["extra"]
    numeric = st.sampled_from(sorted(k for k in base if base[k].dtype.kind == "f"))  # t, pose_ref, q, ...
    texts = st.text(st.characters(codec="utf-8"), max_size=12)
    scene_texts = st.sampled_from([(ROOT / "problems" / f).read_text() for f in
                                   ("flores_slider_crank.yaml", "paper_circle_graph.yaml", "rrr3_circle.yaml")]
                                  + ["", "[1, 2]", "mechanism: !!python/object:os.system {}", "a: [", "name: x"])
    arrays = hnp.arrays(st.one_of(hnp.floating_dtypes(), hnp.integer_dtypes(), hnp.boolean_dtypes(),
                                  hnp.unicode_string_dtypes(max_len=4), hnp.complex_number_dtypes()),
                        hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=4))
    values = st.one_of(arrays, texts.map(np.array), st.lists(texts, max_size=3).map(lambda v: np.array(v, str)),
                       scene_texts.map(np.array), st.just(np.array([None, 1], dtype=object)))
    damage = st.one_of(
        st.tuples(st.just("drop"), st.sampled_from(keys)),
        st.tuples(st.just("value"), st.sampled_from(keys), values),
        st.tuples(st.just("rows"), st.one_of(numeric, st.sampled_from(keys)), st.integers(0, 30)),
        st.tuples(st.just("dtype"), st.sampled_from(keys), st.sampled_from(["i8", "f2", "U3", "?", "c16", "O"])),
        st.tuples(st.just("nonfinite"), numeric, st.sampled_from([np.nan, np.inf, -np.inf]),
                  st.integers(0, 10**6)),
        st.tuples(st.just("shift"), st.one_of(st.just("t"), numeric), st.floats(-1e3, 1e3)),
    )

    def damaged(ops):
        data = dict(base)
        for op, key, *arg in ops:
            a = data.get(key)
            if op == "drop":
                data.pop(key, None)
            elif op == "value":
                data[key] = arg[0]
            elif a is None:
                continue
            elif op == "rows":
                data[key] = a[:arg[0]] if a.ndim and arg[0] <= len(a) else np.resize(a, (arg[0],) + a.shape[1:])
            elif op == "dtype":
                try:
                    data[key] = a.astype(arg[0])
                except (ValueError, TypeError, OverflowError):
                    continue
            elif op == "nonfinite" and a.size and a.dtype.kind in "fc":
                a = a.copy()
                a.flat[arg[1] % a.size] = arg[0]
                data[key] = a
            elif op == "shift" and a.dtype.kind in "fc":
                data[key] = a + arg[0]
        return data

    @settings(max_examples=40, deadline=None, suppress_health_check=list(HealthCheck))
    @given(ops=st.lists(damage, min_size=1, max_size=3))
    @example(ops=[("shift", "t", -1.0)])    # a grid before 0 s: nothing to draw (IndexError once)
    def check(ops):
        np.savez(d / MOTION, **damaged(ops))
        try:
            data, scene = load_motion(d)
        except Rrr4Error as e:
            assert "\n" not in str(e) and str(e).startswith("result_dir: "), str(e)
            return
        fig, update, n = build(data, rrr4.build(scene), frames=3)
        try:
            for k in range(n):
                update(k)
        finally:
            plt.close(fig)

    check()

"""`motion.gif`: the mechanism moving, every arm of a study side by side.

A study saves what the animation needs in its result directory (:func:`save_motion`):
``motion.npz`` with the output instants, every arm's body coordinates q, the eccentricity
and force of every clearance joint (the dry normal force, and the total force on the
journal: dry + oil film), the commanded task path, and the scene's YAML data (the scene in
memory, :attr:`rrr4.scene.Scene.data`, its tables inlined). :func:`render` draws from that file alone, so ``rrr4 animate
RESULT_DIR`` remakes the animation without simulating again.

A driven scene (no task, a revolute driver) is shown over two driver revolutions after the
first, so that a fast crank is not aliased by the frame rate. Drawn to scale [m]: every body
as the polygon through its named points, the ground points, the joints, the commanded path
(dashed) and the task point's actual trace. Every clearance joint carries a circle drawn at
its bearing point, the clearance magnified by a factor M (in the legend) so the journal
centre's eccentricity is visible; the journal centre is coloured by the joint's total
force (dry contact + oil film). A time stamp in the title.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import yaml  # noqa: E402
from matplotlib.animation import FFMpegWriter, FuncAnimation, PillowWriter, writers  # noqa: E402

from ..checks import argument, describe  # noqa: E402
from ..errors import Rrr4Error  # noqa: E402
from ..mechanism import Model  # noqa: E402
from ..problem import Problem  # noqa: E402
from ..scene import GROUND, Scene, load_yaml, parse_scene  # noqa: E402
from .figures import STYLE, save_figure  # noqa: E402
from .study import ARMS  # noqa: E402

__all__ = ["save_motion", "load_motion", "render", "MOTION", "FRAMES", "FPS"]

MOTION = "motion.npz"
FRAMES = 60         # frames of the animation (fewer if the result has fewer samples); ~0.25 s each to draw
FPS = 10            # frames per second of the GIF
LABELS = {k: v["label"] for k, v in STYLE.items()}


def save_motion(study, path: Path, rate: float | None = None) -> Path | None:
    """Write ``motion.npz`` of `study` at `rate` [Hz] (default the path's sample rate); None
    (nothing written) when the scene's YAML text is not available (a scene built in Python)."""
    scene: Scene = study.scene
    if scene.data is None or scene.read is None:
        return None
    parsed = scene.read(scene.data, name=scene.name)  # the scene in memory (its tables inlined), not its file
    # the data's scene, but for the path (an optimal law or motion replayed: pose_ref holds it)
    if replace(parsed, path=scene.path) != scene:
        return None     # changed in memory since it was read (dataclasses.replace): its data does not describe it
    text = yaml.safe_dump(scene.data, sort_keys=False)
    base = next(iter(study.arms.values())).simulation
    rate = scene.path.sample_rate if rate is None else rate
    every = max(int(round(1.0 / (rate * (base.t[1] - base.t[0])))), 1)
    rows = np.arange(0, len(base.t), every)
    data = {"t": base.t[rows], "pose_ref": base.pose_ref[rows], "arms": np.array(list(study.arms)),
            "scene_yaml": np.array(text), "scene_name": np.array(scene.name)}
    for name, arm in study.arms.items():
        sim = arm.simulation
        data[f"q_{name}"] = sim.q[rows]
        data[f"eccentricity_{name}"] = sim.eccentricity[rows]
        data[f"normal_force_{name}"] = sim.normal_force[rows]
        data[f"total_force_{name}"] = np.linalg.norm(sim.contact_force[rows], axis=2)  # dry + film, on the journal
        data[f"clearance_joints_{name}"] = np.array(sim.clearance_joints, dtype=str)
    np.savez_compressed(path, **data)
    return path


def load_motion(result_dir) -> tuple[dict, Scene]:
    """The saved motion of a result directory and its scene. Raises Rrr4Error in one line
    when the directory is not an rrr4 result or holds no motion data."""
    d = Path(result_dir)
    if not d.is_dir() or not (d / "summary.json").is_file():
        raise Rrr4Error(f"result_dir: '{result_dir}' is not an rrr4 result directory (it holds no summary.json; "
                        "make one with rrr4 run SCENE)")
    f = d / MOTION
    if not f.is_file():
        raise Rrr4Error(f"result_dir: '{result_dir}' holds no motion data ({MOTION}); rerun rrr4 run on its scene "
                        "to save it")
    try:
        with np.load(f, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
        scene = parse_scene(load_yaml(str(data["scene_yaml"]), f"{f}: scene_yaml"), name=str(data["scene_name"]))
    except Exception as e:  # noqa: BLE001 - a damaged file is one line for the user
        raise Rrr4Error(f"result_dir: '{f}' cannot be read ({type(e).__name__}: {str(e).splitlines()[0][:160]})") \
            from None
    _check_motion(data, Problem.from_scene(scene).model, f)
    return data, scene


def _check_motion(data: dict, model: Model, f) -> None:
    """`data` holds what :func:`save_motion` writes, for the scene it claims: the arm names of
    a study, the time grid, finite coordinates of the scene's bodies, and the contact arrays of
    its clearance joints; else one Rrr4Error line naming the entry."""
    def bad(key, why):
        return Rrr4Error(f"result_dir: '{f}' is not a motion file rrr4 wrote ({key}: {why})")

    def array(key, ndim):
        if key not in data:
            raise bad(key, "missing")
        a = data[key]
        if a.ndim != ndim:
            raise bad(key, f"{a.ndim} dimensions, expected {ndim}")
        return a

    arms = array("arms", 1)
    if arms.dtype.kind != "U" or not arms.size or any(a not in ARMS for a in arms.tolist()):
        raise bad("arms", f"{describe(arms.tolist())} (the names of a study's arms: {', '.join(ARMS)})")
    t = array("t", 1)
    if t.dtype.kind != "f" or t.size < 1 or not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0) or t[0] < 0:
        raise bad("t", "not a finite, non-decreasing time grid from 0 s")
    n = t.size
    shapes = {"pose_ref": (n, 3)}
    for arm in arms.tolist():
        joints = array(f"clearance_joints_{arm}", 1).tolist()
        if any(j not in model.clearance_joints for j in joints):
            raise bad(f"clearance_joints_{arm}", f"{describe(joints)} are not clearance joints of the scene")
        nc = len(joints)
        shapes.update({f"q_{arm}": (n, model.nq), f"eccentricity_{arm}": (n, nc, 2), f"normal_force_{arm}": (n, nc)})
        if f"total_force_{arm}" in data:  # written since the film's force joined the colour (older files lack it)
            shapes[f"total_force_{arm}"] = (n, nc)
    for key, shape in shapes.items():
        a = array(key, len(shape))
        if a.shape != shape:
            raise bad(key, f"shape {a.shape}, the scene and the time grid make {shape}")
        if a.dtype.kind != "f" or not np.all(np.isfinite(a)):
            raise bad(key, "not finite numbers")


def body_points(model: Model, q: np.ndarray) -> dict[str, np.ndarray]:
    """Global positions (k, 2) [m] of every body's named points at coordinates q (nq,)."""
    out = {}
    for b in model.graph.bodies:
        x, y, th = q[model.coordinates(b.name)]
        c, s = np.cos(th), np.sin(th)
        local = np.array([p for _, p in b.points]).reshape(-1, 2)
        out[b.name] = np.c_[x + c * local[:, 0] - s * local[:, 1], y + s * local[:, 0] + c * local[:, 1]]
    return out


def joint_positions(model: Model, q: np.ndarray) -> np.ndarray:
    """(n_joints, 2) [m]: each joint's point on its first body (the bearing side as drawn)."""
    pts = []
    for j in model.graph.joints:
        body, local = j.bodies[0], np.asarray(j.points[0], float)
        if body == GROUND:
            pts.append(local)
            continue
        x, y, th = q[model.coordinates(body)]
        c, s = np.cos(th), np.sin(th)
        pts.append([x + c * local[0] - s * local[1], y + s * local[0] + c * local[1]])
    return np.array(pts)


def _task_points(model: Model, q: np.ndarray) -> np.ndarray:
    return np.array(model.task_pose_function.map(q.shape[0])(q.T)).T[:, :2]


MAX_FRAMES = 10_000


def render(result_dir, out_file=None, frames: int | None = None, progress: bool = True, fps: float | None = None,
           magnification: float | None = None):
    """Write the animation of a saved result (default RESULT_DIR/motion.gif); return its path.
    frames: how many (default :data:`FRAMES`, fewer when the result has fewer samples); fps:
    frames per second (default :data:`FPS`); magnification: the factor the clearance circles
    and eccentricities are drawn at (default: the largest circle 4 % of the drawing). An
    ``.mp4`` file needs ffmpeg (refused in one line without it). The figure and its per-frame
    update function are built by :func:`build`."""
    frames = FRAMES if frames is None else frames
    if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or not 1 <= frames <= MAX_FRAMES:
        raise Rrr4Error(f"--frames: {describe(frames)} is not allowed (an integer from 1 to {MAX_FRAMES})")
    fps = FPS if fps is None else argument("--fps", fps)
    if magnification is not None:
        magnification = argument("--magnification", magnification)
    out = Path(out_file) if out_file else Path(result_dir) / "motion.gif"
    if out.suffix.lower() not in (".gif", ".mp4"):
        raise Rrr4Error(f"--out: '{out}' is not allowed (a .gif file, or .mp4 when ffmpeg is installed)")
    if out.suffix.lower() == ".mp4" and not writers.is_available("ffmpeg"):
        raise Rrr4Error(f"--out: '{out}' is not allowed (an .mp4 needs ffmpeg, which is not installed here; "
                        "write a .gif instead)")
    data, scene = load_motion(result_dir)
    fig, update, n = build(data, Problem.from_scene(scene), frames, magnification)
    anim = FuncAnimation(fig, update, frames=n, blit=False)
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=n, desc="animate", unit="frame")
    try:
        writer = PillowWriter(fps=fps) if out.suffix.lower() == ".gif" else FFMpegWriter(fps=fps)
        save_figure(anim, out, writer=writer, dpi=72,
                    progress_callback=(lambda i, total: bar.update(1)) if bar is not None else None)
    finally:
        if bar is not None:
            bar.close()
        plt.close(fig)
    return out


def build(data: dict, problem: Problem, frames: int = FRAMES, magnification: float | None = None):
    """(figure, update(k), frame count): the animation of saved motion `data` of `problem`;
    magnification: of the clearance circles (default: the largest one 4 % of the drawing)."""
    scene, model = problem.scene, problem.model
    arms = [str(a) for a in data["arms"]]
    t = data["t"]
    lo_t, hi_t = 0.0, float(t[-1])
    d = scene.graph.drivers[0] if scene.graph.drivers and model.task is None else None
    if d is not None and d.speed != 0 and scene.graph.joint(d.joint).type == "revolute":
        rev = 2 * np.pi / abs(d.speed)     # a fast driver: two revolutions after the first, not aliased
        lo_t, hi_t = (rev, 3 * rev) if 3 * rev <= t[-1] else (0.0, min(2 * rev, hi_t))
    window = np.flatnonzero((t >= lo_t - 1e-12) & (t <= hi_t + 1e-12))
    idx = window[np.unique(np.linspace(0, len(window) - 1, min(frames, len(window))).round().astype(int))]
    fig, axes = plt.subplots(1, len(arms), figsize=(5.2 * len(arms), 6.2), squeeze=False)
    axes = axes.ravel()
    # common limits: every body point of every arm at every frame
    ground = np.array([j.points[0] for j in scene.graph.joints if j.bodies[0] == GROUND]).reshape(-1, 2)
    allp = np.vstack([np.vstack(list(body_points(model, data[f"q_{a}"][k]).values())) for a in arms for k in idx]
                     + [ground])
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    span = max(hi - lo)
    pad = 0.08 * span
    # magnified clearance circles: drawn radius 4 % of the drawing, the same factor for every joint
    clear = [j for j in scene.graph.joints if j.clearance]
    c_max = max((j.radial_clearance for j in clear), default=1.0)
    R = 0.04 * span
    mag = R / c_max if magnification is None else magnification
    force = {a: data.get(f"total_force_{a}", data[f"normal_force_{a}"]) for a in arms}  # dry + film (older: dry)
    fmax = max((float(np.max(force[a], initial=0.0)) for a in arms), default=1.0) or 1.0
    cmap = plt.get_cmap("viridis")
    tasks = {a: _task_points(model, data[f"q_{a}"]) for a in arms} if model.task else {}
    artists = []
    for ax, a in zip(axes, arms, strict=True):
        ax.set_aspect("equal")
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_title(LABELS.get(a, a))
        ax.plot(ground[:, 0], ground[:, 1], "k^", ms=9, label="ground joints")
        if model.task:
            ax.plot(data["pose_ref"][:, 0], data["pose_ref"][:, 1], "--", color="0.5", lw=1.0, label="commanded path")
        # a body with a single point (a slider block) is drawn as a square
        lines = {b.name: ax.plot([], [], "-s" if len(b.points) == 1 else "-", color="tab:blue", lw=3, ms=14,
                                 solid_capstyle="round")[0] for b in scene.graph.bodies}
        joints_art = ax.plot([], [], "o", mfc="white", mec="k", ms=5, label="joints")[0]
        trace = ax.plot([], [], "-", color="tab:red", lw=1.0, label="task point, actual")[0] if model.task else None
        circles, dots = [], []
        names = [str(x) for x in data[f"clearance_joints_{a}"]]
        for j in clear:
            circ = plt.Circle((0, 0), j.radial_clearance * mag, fill=False, color="k", lw=0.8)
            ax.add_patch(circ)
            circles.append(circ)
            dots.append(ax.plot([], [], "o", ms=5)[0])
        lines[scene.graph.bodies[0].name].set_label("bodies")
        artists.append((lines, joints_art, trace, circles, dots, names))
    shown = f"{mag:.0f}" if mag >= 10 else f"{mag:.3g}"
    handles = [plt.Line2D([], [], color="k", lw=0.8, label=f"clearance circles x{shown}, journal centre "
                          f"(colour: the joint's total force, dry + film, 0 to {fmax:.3g} N)")] if clear else []
    fig.legend(handles=axes[0].get_legend_handles_labels()[0] + handles, loc="lower center", ncol=3, fontsize=7,
               frameon=False)
    stamp = fig.suptitle("")

    def update(i: int):
        k = idx[i]
        for a, (lines, joints_art, trace, circles, dots, names) in zip(arms, artists, strict=True):
            q = data[f"q_{a}"][k]
            for b, pts in body_points(model, q).items():
                closed = np.vstack([pts, pts[:1]]) if len(pts) > 2 else pts
                lines[b].set_data(closed[:, 0], closed[:, 1])
            jp = joint_positions(model, q)
            joints_art.set_data(jp[:, 0], jp[:, 1])
            if trace is not None:
                trace.set_data(tasks[a][:k + 1, 0], tasks[a][:k + 1, 1])
            for j, circ, dot in zip(clear, circles, dots, strict=True):
                centre = jp[model.joint_names.index(j.name)]
                circ.center = tuple(centre)
                if j.name in names:
                    m = names.index(j.name)
                    e = data[f"eccentricity_{a}"][k, m]
                    # the bearing is on the body that does not carry the journal; drawn at the joint
                    dot.set_data([centre[0] + mag * e[0]], [centre[1] + mag * e[1]])
                    dot.set_color(cmap(min(float(force[a][k, m]) / fmax, 1.0)))
                else:
                    dot.set_data([centre[0]], [centre[1]])
                    dot.set_color("k")
        stamp.set_text(f"{scene.name}: t = {t[k]:.3f} s")
        return []

    update(0)
    fig.tight_layout(rect=(0, 0.09, 1, 1))
    return fig, update, len(idx)

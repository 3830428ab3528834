"""Parameter sweeps and tolerance Monte Carlo of the study, on Dask (DESIGN section 8).

A spec (YAML) names a base ``scene`` (a path relative to the spec file, or absolute), an
optional ``t_end`` [s], an optional ``skip`` [s] (the start-up window the windowed metrics
discard, 0 <= skip < t_end of every case; see :mod:`rrr4.results.metrics`), the ``arms``
to run, and

- ``grid``: scene key paths -> lists of values, run as their Cartesian product, e.g.
  ``joints.radial_clearance: [5.0e-5, 1.0e-4]``;
- ``monte_carlo``: ``samples``, ``seed`` and ``keys``: key path -> ``{normal: {std, mean}}``
  or ``{uniform: [low, high]}`` (``mean`` defaults to the base scene's value at that key).

Key paths are dotted, with ``[i]`` for list items: ``mechanism.chains[0].base[1]``. A grid
and a Monte Carlo together run every Monte Carlo sample at every grid point.

The arms are those ``rrr4 run`` runs for the scene's kind (:mod:`rrr4.studies.study`): on a
scene with a task body :data:`rrr4.results.study.PRELOAD_ARMS` (default ``with_preload`` and
``without_preload``), with the columns :data:`METRICS`; on a driven scene (no task body,
drivers set the motion) :data:`rrr4.results.study.DRIVEN_ARMS` (default both: the scene
and its ideal twin), with the columns :data:`DRIVEN_METRICS`
(:func:`rrr4.results.metrics.driven_scalar_metrics`: impacts per driver revolution, the
acceleration deviation against the ideal twin, which a ``with_clearance`` arm simulates
even when the spec does not ask for its row, the driver efforts, penetration and peak
contact force). A metric that does not apply to an arm is an empty cell. Every row ends with
``converged``: the energy audit's verdict on that arm (:mod:`rrr4.simulation.verdict`); a
number of a row that says False is not to be trusted. Every case is
built and validated as a scene before anything runs; a bad spec or case value is one
:class:`~rrr4.errors.SceneError` line naming the key.

Cases run on ``dask.distributed``: a local cluster of worker processes on this machine by
default, or an existing cluster (``scheduler='tcp://host:port'``). A case that fails (a
blow-up; an infeasible preload only warns) is recorded with its error and the sweep goes on.
Each finished case appends its rows (one per arm) to ``results.csv`` at once, so an interrupted
sweep loses no finished case; a re-run of the same spec into the same directory skips the
cases already there (keyed by a hash of the case's scene).
"""

from __future__ import annotations

import csv
import hashlib
import io
import itertools
import json
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from ..checks import describe
from ..errors import Rrr4Error, SceneError
from ..files import check_writable, stop_requested
from ..mechanism import check_scene
from ..results.metrics import (
    DRIVEN_SCALAR_METRICS,
    SCALAR_METRICS,
    check_skip,
    driven_scalar_metrics,
    driven_window,
    scalar_metrics,
)
from ..results.study import DRIVEN_ARMS, PRELOAD_ARMS
from ..scene import Scene, get_key, key_steps, parse_scene, read_scene, read_yaml

__all__ = ["sweep", "load_spec", "SweepSpec", "METRICS", "DRIVEN_METRICS", "spec_arms", "DISTRIBUTIONS", "case_options",
           "GEOMETRY_KEYS", "PATH_KEYS"]

# the CSV columns of each arm, scene with a task body; converged: the energy audit's verdict on the arm
METRICS = (*SCALAR_METRICS, "wall_time_s", "converged")
DRIVEN_METRICS = (*DRIVEN_SCALAR_METRICS, "wall_time_s", "converged")  # those of a driven scene
DISTRIBUTIONS = ("normal", "uniform")
SPEC_KEYS = ("scene", "t_end", "skip", "arms", "grid", "monte_carlo")
MAX_CASES = 100_000
MAX_WORKERS_PER_CORE = 4  # local worker processes a machine holds per core (each a Python with CasADi)
# a case's scene text, read in the worker with libyaml's parser where PyYAML has it (about 8x
# faster than the pure-Python one: 4 ms of a warm reference case; the same constructors)
CASE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep: the base scene and its file (None for a scene built in Python), t_end
    (None: the path's duration), the arms, the varied keys, the cases (key -> value dicts, in
    order, each set on the base scene with :meth:`rrr4.scene.Scene.with_values`), and the
    start-up window skip [s] the metrics discard; driven: the scene has no task body (its
    drivers set the motion), so its arms are DRIVEN_ARMS."""
    scene: Scene
    scene_path: Path | None
    t_end: float | None
    arms: tuple[str, ...]
    keys: tuple[str, ...]
    cases: tuple[dict, ...]
    grid_keys: tuple[str, ...] = ()
    mc_keys: tuple[str, ...] = ()
    skip: float = 0.0
    driven: bool = False

    @property
    def base(self) -> dict:
        """The base scene's YAML data (:attr:`rrr4.scene.Scene.data`, its tables inlined)."""
        return self.scene.data

    @property
    def name(self) -> str:
        """The base scene file's stem, or the name of a scene built in Python."""
        return self.scene.name if self.scene_path is None else self.scene_path.stem


def spec_arms(driven: bool) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(allowed arms, default arms) of a sweep on a driven scene or on one with a task body."""
    return (DRIVEN_ARMS, DRIVEN_ARMS) if driven else (PRELOAD_ARMS, ("with_preload", "without_preload"))


def _number(key: str, v, what: str) -> float:
    try:  # math.isfinite takes any int (a float conversion of one beyond 1e308 overflows)
        finite = not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v)
    except OverflowError:
        finite = False
    if not finite:
        raise SceneError(f"{key}: {describe(v)} is not allowed ({what} must be a finite number)")
    return float(v)


def load_spec(path) -> SweepSpec:
    """Read and validate a sweep spec file (every case is built as a scene)."""
    p = Path(path)
    data = read_yaml(p, "sweep spec")
    if not isinstance(data, dict):
        raise SceneError(f"sweep spec: {describe(data)} is not allowed (a mapping with keys {', '.join(SPEC_KEYS)})")
    return parse_spec(data, p.parent)


def parse_spec(data: dict, root: Path = Path(".")) -> SweepSpec:
    """Validate a spec mapping; relative scene paths are taken from `root`. Its ``scene`` is
    the base scene's YAML file or, from Python, a :class:`~rrr4.scene.Scene` (read from a file,
    or parsed from a mapping: it holds its YAML data, which the cases change)."""
    bad = sorted(set(data) - set(SPEC_KEYS))
    if bad:
        raise SceneError(f"{bad[0]}: unknown key of a sweep spec (allowed: {', '.join(SPEC_KEYS)})")
    scene, scene_path = data.get("scene"), None
    if isinstance(scene, Scene):
        scene.with_values({})  # it holds YAML data that still describes it
    elif not isinstance(scene, str) or "\0" in scene:  # a NUL is no path
        raise SceneError(f"scene: {describe(scene)} is not allowed (the base scene's YAML file, or a Scene)")
    else:
        scene_path = (root / scene).resolve()
        scene = read_scene(scene_path)  # its table files inlined in its data, so the cases carry them
    # the base itself is a valid scene that assembles along its path
    driven = check_scene(scene).graph.task is None
    base = scene.data
    t_end = data.get("t_end")
    if t_end is not None:
        t_end = _number("t_end", t_end, "t_end [s]")
        if t_end <= 0:
            raise SceneError(f"t_end: {t_end:g} is not allowed (must be > 0 s)")
    skip = data.get("skip", 0.0)
    if isinstance(skip, bool) or not isinstance(skip, (int, float)):
        raise SceneError(f"skip: {describe(skip)} is not allowed (the start-up window [s] the metrics discard, "
                         "a number with 0 <= skip < t_end)")
    allowed, default = spec_arms(driven)
    kind = "a driven scene (no task body)" if driven else "a scene with a task body"
    arms = data.get("arms", list(default))
    if not isinstance(arms, list) or not arms:
        raise SceneError(f"arms: {describe(arms)} is not allowed (a list of: {', '.join(allowed)})")
    for a in arms:
        if a not in allowed:
            raise SceneError(f"arms: {describe(a)} is not allowed on {kind} (choose from: {', '.join(allowed)})")
    grid = data.get("grid") or {}
    mc = data.get("monte_carlo")
    if not isinstance(grid, dict):
        raise SceneError(f"grid: {describe(grid)} is not allowed (scene key paths -> lists of values)")
    if not grid and mc is None:
        raise SceneError("grid: no grid and no monte_carlo is not allowed (give at least one key path with a list "
                         "of values, or a monte_carlo)")
    for k, vals in grid.items():
        _key("grid", k)
        if not isinstance(vals, list) or not vals:
            raise SceneError(f"grid.{k}: {describe(vals)} is not allowed (a non-empty list of values)")
    n_points = math.prod(len(v) for v in grid.values())
    n_samples = mc.get("samples", 1) if isinstance(mc, dict) and isinstance(mc.get("samples"), int) else 1
    if n_points * n_samples > MAX_CASES:  # counted, not expanded
        raise SceneError(f"grid: {n_points * n_samples:,} cases is not allowed (at most {MAX_CASES:,})")
    points = [dict(zip(grid, combo, strict=True)) for combo in itertools.product(*grid.values())] or [{}]
    samples = [{}]
    mc_keys: list = []
    if mc is not None:
        samples, mc_keys = _monte_carlo(mc, base)
    cases = tuple({**pt, **smp} for pt in points for smp in samples)
    keys = tuple(grid) + tuple(k for k in mc_keys if k not in grid)
    for case in cases:  # every case is a valid scene before anything runs, and runs longer than skip
        case_base, _ = case_scene(scene, case)
        if (case_base.graph.task is None) != driven:
            values = ", ".join(f"{k} = {describe(v)}" for k, v in case.items())
            raise SceneError(f"grid: the case {values} is not allowed (it makes {kind} into another kind; the arms "
                             "of a sweep follow its base scene's kind)")
        skip = check_skip(skip, case_base.path.duration if t_end is None else t_end)
    return SweepSpec(scene, scene_path, t_end, tuple(arms), keys, cases, tuple(grid), tuple(mc_keys), float(skip),
                     driven)


SCHEDULER_TIMEOUT = 20.0  # [s] an address that is not a Dask scheduler answering within this ends in one line
SCHEDULER_SCHEMES = ("tcp",)


def _scheduler_address(scheduler) -> str:
    """`scheduler` as a Dask address tcp://host:port (a bare host:port means tcp), or a
    one-line SceneError naming it."""
    if not isinstance(scheduler, str):
        raise SceneError(f"--scheduler: {describe(scheduler)} is not allowed (an address such as "
                         "tcp://127.0.0.1:8786)")
    scheme, sep, rest = scheduler.partition("://")
    if not sep:
        scheme, rest = "tcp", scheduler
    host, _, port = rest.rpartition(":")
    if scheme not in SCHEDULER_SCHEMES:
        why = ("it needs the CA file, client certificate and key of Dask's Security, which rrr4 takes no option "
               "for yet" if scheme.lower() in ("tls", "wss") else "rrr4 reaches a Dask scheduler over plain TCP")
        shown = f"{scheme}://" if scheme.isascii() and scheme.isalnum() and len(scheme) <= 12 else "that scheme"
        raise SceneError(f"--scheduler: {describe(scheduler)} is not allowed (rrr4 supports tcp://HOST:PORT or "
                         f"HOST:PORT only; {shown} is not supported: {why})")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise SceneError(f"--scheduler: {describe(scheduler)} is not allowed (an address tcp://HOST:PORT, "
                         "port 1 to 65535)")
    return f"{scheme}://{rest}"


def _connect(client_class, scheduler):
    """A Dask client of the scheduler at `scheduler`, or a one-line SceneError naming the
    address within SCHEDULER_TIMEOUT seconds: whatever answers there (nothing, an HTTP
    server, a server that accepts and stays silent) and whatever the client raises."""
    import threading
    address = _scheduler_address(scheduler)
    box: dict = {}

    def connect():
        try:
            box["client"] = client_class(address, timeout=f"{SCHEDULER_TIMEOUT / 2:g}s")
        except BaseException as e:  # noqa: BLE001 - anything: one line for the user
            box["error"] = e

    thread = threading.Thread(target=connect, name="rrr4-scheduler-connect", daemon=True)
    thread.start()
    thread.join(SCHEDULER_TIMEOUT)
    if "client" in box:
        return box["client"]
    why = (f"{type(box['error']).__name__}: {str(box['error']).splitlines()[0][:120] if str(box['error']) else ''}"
           if "error" in box else f"no Dask scheduler answered within {SCHEDULER_TIMEOUT:g} s")
    raise SceneError(f"--scheduler: {address!r} is not a reachable Dask scheduler ({why})")


def _key(where: str, k) -> None:
    """A spec's key path `k` under `where` (grid or monte_carlo.keys): a string of dotted
    scene keys, list items as [i]; SceneError otherwise."""
    if not isinstance(k, str):
        raise SceneError(f"{where}: key {describe(k)} is not allowed (a dotted scene key path, list items as [i], "
                         "e.g. mechanism.chains[0].base[1])")
    key_steps(k)


def _monte_carlo(mc, base) -> tuple[list[dict], list[str]]:
    if not isinstance(mc, dict) or set(mc) - {"samples", "seed", "keys"}:
        raise SceneError(f"monte_carlo: {describe(mc)} is not allowed (samples, seed and keys)")
    n = mc.get("samples")
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_CASES:
        raise SceneError(f"monte_carlo.samples: {describe(n)} is not allowed (an integer from 1 to {MAX_CASES})")
    seed = mc.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise SceneError(f"monte_carlo.seed: {describe(seed)} is not allowed (an integer >= 0)")
    keys = mc.get("keys")
    if not isinstance(keys, dict) or not keys:
        raise SceneError(f"monte_carlo.keys: {describe(keys)} is not allowed (key path -> distribution)")
    rng = np.random.default_rng(seed)
    draws = {}
    for k, dist in keys.items():
        _key("monte_carlo.keys", k)
        key = f"monte_carlo.keys.{k}"
        if not isinstance(dist, dict) or len(dist) != 1 or next(iter(dist)) not in DISTRIBUTIONS:
            raise SceneError(f"{key}: {describe(dist)} is not allowed ({{normal: {{std, mean}}}} or "
                             "{uniform: [low, high]})")
        kind, par = next(iter(dist.items()))
        if kind == "normal":
            if not isinstance(par, dict) or "std" not in par or set(par) - {"std", "mean"}:
                raise SceneError(f"{key}.normal: {describe(par)} is not allowed (std, and mean if the base scene "
                                 "has no number at that key)")
            std = _number(f"{key}.normal.std", par["std"], "std")
            mean = par.get("mean", get_key(base, str(k)))
            mean = _number(f"{key}.normal.mean", mean, "the mean (or the base scene's value)")
            if std < 0:
                raise SceneError(f"{key}.normal.std: {std:g} is not allowed (must be >= 0)")
            draws[str(k)] = mean + std * rng.standard_normal(n)
        else:
            if not isinstance(par, list) or len(par) != 2:
                raise SceneError(f"{key}.uniform: {describe(par)} is not allowed ([low, high])")
            lo, hi = (_number(f"{key}.uniform", v, "a bound") for v in par)
            if hi < lo:
                raise SceneError(f"{key}.uniform: [{lo:g}, {hi:g}] is not allowed (low <= high)")
            draws[str(k)] = rng.uniform(lo, hi, n)
    return [{k: float(v[i]) for k, v in draws.items()} for i in range(n)], list(draws)


def case_scene(scene: Scene, case: dict) -> tuple[Scene, str]:
    """(Scene, YAML text) of one case: the base `scene` with the case's values set
    (:meth:`rrr4.scene.Scene.with_values`), and its data as the text a worker reads."""
    try:
        out = scene.with_values(case)
        if any(k.startswith(("mechanism.", "path.")) for k in case):  # it must still assemble along its path
            check_scene(out)
    except SceneError as e:
        values = ", ".join(f"{k} = {describe(v)}" for k, v in case.items())
        raise SceneError(f"{e} (in the case {values})") from None
    return out, yaml.safe_dump(out.data, sort_keys=True)


def case_id(text: str, t_end, arms, skip: float = 0.0) -> str:
    """Hash of a case: its scene's YAML text, t_end, arms and skip (left out when 0, so the
    cases of specs without one keep their ids)."""
    return hashlib.sha256(json.dumps([text, t_end, list(arms), *([skip] if skip else [])]).encode()).hexdigest()[:16]


# Keys of the mechanism's geometry and masses. A spec that varies one runs every case with
# them as inputs of the compiled equations (simulate's inputs='geometry') and the
# controller's references tabulated per case (references='sampled': the closed-form
# controller's geometry is a constant of its code, so only its feedback law is compiled),
# and so compiles once per structure like any other sweep. A graph joint's clearance
# settings (mechanism.joints[i].clearance) are contact numbers, inputs anyway.
# Keys of the path: a continuous controller (no control rate) or the prescribed mode evaluates
# the path inside the right-hand side, so a spec that varies one on such a scene tabulates the
# references per case (references='sampled'); a sampled controller takes the path's values
# at its instants as frame inputs anyway.
GEOMETRY_KEYS = ("mechanism.",)
PATH_KEYS = ("path.",)


def case_options(spec: SweepSpec) -> dict:
    """The options of :func:`rrr4.simulate` for the cases of `spec` (see GEOMETRY_KEYS and
    PATH_KEYS), so that a sweep compiles once per structure."""
    opts = {}
    if any(k.startswith(GEOMETRY_KEYS) and ".clearance." not in k for k in spec.keys):
        opts = {"inputs": "geometry", "references": "sampled"}
    continuous = (spec.base.get("actuation") or {}).get("control_rate") is None
    if continuous and any(k.startswith(PATH_KEYS) for k in spec.keys):
        opts["references"] = "sampled"
    return opts


# What a warm case finds built in its worker (Problem.structure): the equations, ODE systems
# and their compiled stepping ('plant'); the controller step ('controller'); the preload's
# sign choice and the kinematic mechanism ('preload').
STRUCTURES = ("plant", "controller", "preload")


def _built(problems) -> list[tuple[bool, ...]]:
    """Per problem, whether each of its STRUCTURES holds anything built."""
    return [tuple(bool(p.structure(k).memoized()) for k in STRUCTURES) for p in problems]


def run_case(text: str, name: str, t_end, arms, jit: bool = False, options: dict | None = None,
             skip: float = 0.0) -> tuple[list[dict], int, tuple[str, ...]]:
    """(the rows (one per arm) of one case: metrics of each arm's simulation
    (:func:`rrr4.results.metrics.scalar_metrics` after `skip` [s], or on a driven scene
    :func:`rrr4.results.metrics.driven_scalar_metrics` against its ideal twin, from outputs
    at every step as in `rrr4 run`, and its wall time), or status 'failed' with the error;
    the C libraries this case compiled; the STRUCTURES it reused: those that every arm which
    uses one found built by an earlier case in this worker). jit: step in compiled C (the
    shared on-disk cache; RRR4_JIT=0 still says no); options: :func:`case_options`. Runs in a
    Dask worker; imports nothing Dask."""
    from ..integrators.compiled import compilations
    from ..problem import Problem
    from ..simulation import simulate
    from .study import arm_scene
    rows = []
    before = compilations()
    try:
        problem = Problem.from_scene(parse_scene(yaml.load(text, Loader=CASE_LOADER), name=name, source=""))
    except Rrr4Error as e:
        return [{"arm": a, "status": "failed", "error": str(e).splitlines()[0]} for a in arms], 0, ()
    driven = problem.model.task is None
    # a driven scene's clearance arm is measured against its ideal twin, run even without its row
    runs = [*arms, *(["ideal"] if driven and "with_clearance" in arms and "ideal" not in arms else [])]
    problems = [Problem.from_scene(arm_scene(problem, arm)) for arm in runs]
    found = _built(problems)
    options = dict(options or {})
    if driven:  # impacts and deviations are counted on the outputs: keep every step, as `rrr4 run` does
        options.setdefault("output_rate", 1.0 / options.get("step", problem.scene.integrator.step))
    sims: dict = {}
    for arm, arm_problem in zip(runs, problems, strict=True):
        wall = time.perf_counter()
        try:
            sims[arm] = simulate(arm_problem, t_end=t_end, jit=None if jit else False, **options)
        except Exception as e:  # recorded, the sweep goes on
            rows.append({"arm": arm, "status": "failed", "error": f"{type(e).__name__}: {str(e).splitlines()[0]}"})
            continue
        rows.append({"arm": arm, "status": "ok", "error": "", "wall_time_s": time.perf_counter() - wall})
    if driven:
        t_from, revolution = driven_window(problem.scene, problem.scene.path.duration if t_end is None else t_end,
                                           skip)
    for row in rows:
        if row["status"] == "ok":
            sim = sims[row["arm"]]
            row.update(driven_scalar_metrics(sim, None if row["arm"] == "ideal" else sims.get("ideal"), t_from,
                                             revolution) if driven else scalar_metrics(sim, skip),
                       converged=sim.verdict.converged)
    rows = [r for r in rows if r["arm"] in arms]
    used = _built(problems)
    reused = tuple(k for i, k in enumerate(STRUCTURES)
                   if any(u[i] for u in used) and all(f[i] for f, u in zip(found, used, strict=True) if u[i]))
    return rows, compilations() - before, reused


def _columns(spec: SweepSpec) -> list[str]:
    return ["case", *spec.keys, "arm", "status", "error", *(DRIVEN_METRICS if spec.driven else METRICS)]


def _done(csv_path: Path, columns: list[str]) -> set[str]:
    """Case ids already in results.csv (whose header must match this spec's columns)."""
    if not csv_path.exists():
        return set()
    with csv_path.open(newline="") as f:
        reader = csv.reader(f)
        header = next(reader, None)
        if header is None:
            return set()
        if header != columns:
            raise SceneError(f"--out: {str(csv_path)!r} holds another sweep (columns {', '.join(header[:4])}, ...); "
                             "choose another directory")
        return {row[0] for row in reader if row}


def _append(csv_path: Path, columns: list[str], rows: list[dict]) -> None:
    """Append rows in one write, flushed to disk (a crash loses at most the case being written)."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=columns, lineterminator="\n")
    if not csv_path.exists() or csv_path.stat().st_size == 0:
        w.writeheader()
    w.writerows(rows)
    with csv_path.open("a", newline="") as f:
        f.write(buf.getvalue())
        f.flush()
        os.fsync(f.fileno())


def sweep(spec, out=None, scheduler: str | None = None, workers: int | None = None, progress: bool = False,
          log=None) -> dict:
    """Run a sweep: `spec` is a spec file path, a mapping, or a :class:`SweepSpec`; rows go to
    ``out/results.csv`` (default ``results/sweeps/<spec or scene name>/``). scheduler: the
    address of an existing Dask scheduler (default: a local cluster of `workers` processes,
    default the machine's cores). Writes the figures of :func:`rrr4.results.figures.sweep_figures` from
    all rows. Cases step in compiled C when a C compiler exists (see
    :func:`rrr4.simulation.default_jit`), with :func:`case_options`.
    Returns {'csv': path, 'cases': n, 'skipped': n, 'failed': n, 'rows': list of row dicts of
    this run, 'figures': paths, 'compiled': bool, 'options': the cases' simulate options,
    'compilations': the C libraries the workers compiled (the others came from the shared
    cache), 'reused': structure ('plant', 'controller', 'preload') -> how many cases found it
    built in their worker (:func:`run_case`)}."""
    say = log or (lambda _m: None)
    name = None
    if not isinstance(spec, (str, Path, dict, SweepSpec)):
        raise SceneError(f"spec: {describe(spec)} is not allowed (a sweep spec file, a mapping or a SweepSpec)")
    if isinstance(spec, (str, Path)):
        name = Path(spec).stem
        spec = load_spec(spec)
    elif isinstance(spec, dict):
        spec = parse_spec(spec)
    out = check_writable(Path(out) if out is not None else Path("results") / "sweeps" / (name or spec.name))
    if (out / "results.csv").exists() and not (out / "results.csv").is_file():
        raise SceneError(f"--out: '{out}' is not allowed (its results.csv is not a file)")
    if scheduler is not None:
        _scheduler_address(scheduler)  # before any work
    most = MAX_WORKERS_PER_CORE * (os.cpu_count() or 1)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= most):
        raise SceneError(f"--workers: {describe(workers)} is not allowed (an integer from 1 to {most}: "
                         f"{MAX_WORKERS_PER_CORE} local worker processes per core at most)")
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / "results.csv"
    columns = _columns(spec)
    done = _done(csv_path, columns)
    todo = []
    for case in spec.cases:
        _, text = case_scene(spec.scene, case)
        cid = case_id(text, spec.t_end, spec.arms, spec.skip)
        if cid not in done:
            todo.append((cid, case, text))
            done.add(cid)  # a duplicate case runs once
    skipped = len(spec.cases) - len(todo)
    say(f"{len(spec.cases)} cases x {len(spec.arms)} arms; {skipped} already in {csv_path}, {len(todo)} to run")
    from ..simulation import default_jit
    rows_out, failed, built, jit, options = [], 0, 0, default_jit(), case_options(spec)
    reused = dict.fromkeys(STRUCTURES, 0)
    if todo:
        from dask.distributed import Client, LocalCluster, as_completed
        cluster = None
        if scheduler is None:
            cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                                   dashboard_address=":0")
            client = Client(cluster)
        else:
            client = _connect(Client, scheduler)
        bar = None
        try:
            futures = {client.submit(run_case, text, spec.name, spec.t_end, spec.arms, jit, options,
                                     spec.skip, pure=False):
                       (cid, c) for cid, c, text in todo}
            if progress:
                from tqdm import tqdm
                bar = tqdm(total=len(futures), desc="sweep", unit="case")
            for fut in as_completed(futures):
                if stop_requested():  # an interrupt lost inside a solver (rrr4.files.request_stop)
                    raise KeyboardInterrupt
                cid, case = futures[fut]
                try:
                    rows, n_built, found = fut.result()
                    built += n_built
                    for k in found:
                        reused[k] += 1
                except Exception as e:  # the worker itself died: record, go on
                    rows = [{"arm": a, "status": "failed", "error": f"{type(e).__name__}: {e}"} for a in spec.arms]
                rows = [{"case": cid, **case, **r} for r in rows]
                failed += any(r["status"] != "ok" for r in rows)
                _append(csv_path, columns, rows)
                rows_out += rows
                if bar is not None:
                    bar.update()
        finally:
            if bar is not None:
                bar.close()
            client.close()
            if cluster is not None:
                cluster.close()
    from ..results.figures import sweep_figures
    figures = sweep_figures(csv_path, spec.keys, spec.grid_keys, spec.mc_keys, out, name or spec.name)
    return {"csv": csv_path, "cases": len(spec.cases), "skipped": skipped, "failed": failed, "rows": rows_out,
            "figures": figures, "compiled": jit, "options": options, "compilations": built, "reused": reused}

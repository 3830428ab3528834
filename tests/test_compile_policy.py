"""The default compile policy ('background'): a run whose stepping is not in the compile cache
starts at once in CasADi's virtual machine while a process of its own compiles the C, moves to
the library when it is ready (bit for bit the same states) or leaves it for the next run, and
says what it did."""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import rrr4
from rrr4.codegen import build
from rrr4.integrators import BACKGROUND, RK4, Bathe

from .test_integrators import oscillator

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")


def _frames(method, system, h=1e-3, t_end=0.4, outputs=40, sink=None):
    """The states at 40 outputs of the oscillator, in 20 calls (the blocks a switch waits for)."""
    n = int(round(t_end / h))
    t = np.linspace(0.0, t_end, outputs + 1)
    u = np.column_stack([t[:-1], t[1:]])
    return method.run(system, np.r_[0.0, 1.0, 0.0, 0.0], u, h, n // outputs, chunk=2, sink=sink)


@pytest.mark.parametrize("method", [RK4, Bathe])
def test_a_run_moves_to_the_library_when_it_is_ready_with_the_same_states(method, tmp_path, monkeypatch):
    """The background compiler is replaced by compiling the staged sources in the run's own
    sink after the first block (the real compile, at a known time): the run steps its first
    blocks in the virtual machine and the rest in the library, and its states are the virtual
    machine's and the compiled run's, bit for bit."""
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path))
    started = []
    monkeypatch.setattr(build, "spawn", lambda args, alive: started.append(args))
    rows = []

    def sink(k0, kept):
        rows.append(kept.copy())
        if k0 == 2 and started:  # after the second block: the staged sources compiled now
            build.compile_staged(*started[0])

    run = _frames(method(jit=BACKGROUND), oscillator(3.0), sink=sink)
    assert len(started) == 1 and run.stats["stepping"] == {"compiled": True, "compiled_from_frame": 4}
    assert not list(tmp_path.glob("*.staged"))  # the staging directory is gone
    mixed = np.vstack(rows)
    vm = _frames(method(jit=False), oscillator(3.0)).states
    compiled = _frames(method(jit=True), oscillator(3.0)).states
    assert np.array_equal(mixed, vm) and np.array_equal(mixed, compiled)


def test_a_run_that_ends_first_leaves_the_library_for_the_next(tmp_path, monkeypatch):
    """A real background compiler: the first run steps in the virtual machine to its end (it
    never waits), a process of its own compiles the library, and a later run steps in it."""
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path))
    first = _frames(RK4(jit=BACKGROUND), oscillator(5.0))
    assert first.stats["stepping"]["compiled"] is False or first.stats["stepping"]["compiled_from_frame"] > 0
    for _ in range(600):  # the compiler runs in its own process; wait for its library
        if list(tmp_path.glob("*.so")):
            break
        time.sleep(0.1)
    assert len(list(tmp_path.glob("*.so"))) == 1
    fresh = subprocess.run([sys.executable, "-c", (
        "import numpy as np; from tests.test_compile_policy import _frames; from tests.test_integrators import "
        "oscillator; from rrr4.integrators import RK4, BACKGROUND; r = _frames(RK4(jit=BACKGROUND), oscillator(5.0)); "
        "print(r.stats['stepping']); np.save('states.npy', r.states)")], cwd=tmp_path, capture_output=True,
        text=True, env={"RRR4_CACHE": str(tmp_path), "PYTHONPATH": str(Path(__file__).resolve().parents[1]),
                        "PATH": "/usr/bin:/bin"})
    assert fresh.returncode == 0, fresh.stderr
    assert fresh.stdout.strip() == "{'compiled': True, 'compiled_from_frame': None}"
    assert np.array_equal(np.load(tmp_path / "states.npy"), _frames(RK4(jit=False), oscillator(5.0)).states)


def test_the_environment_forces_either_way(monkeypatch):
    from rrr4.simulation import default_jit
    monkeypatch.setenv("RRR4_JIT", "0")
    assert default_jit() is False
    monkeypatch.setenv("RRR4_JIT", "1")
    assert default_jit() is True
    monkeypatch.delenv("RRR4_JIT")
    assert default_jit() == BACKGROUND


def test_simulate_records_how_it_stepped(tmp_path, monkeypatch):
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path))
    monkeypatch.setattr(build, "spawn", lambda args, alive: None)  # no compiler: the VM to the end
    sim = rrr4.simulate(rrr4.load_scene(Path(__file__).resolve().parents[1] / "problems" / "ideal_circle.yaml"),
                        t_end=0.01, jit=BACKGROUND)
    assert sim.stats["jit"] == BACKGROUND
    assert sim.stats["stepping"] == {"compiled": False, "compiled_from_frame": None, "compiled_from_s": None}
    from rrr4.results.metrics import stepping_text
    assert stepping_text(sim) == "virtual machine"


_TINY = {"tiny.c": "double tiny(double x) { return 2.0 * x + 1.0; }\n"}


def test_a_library_compiling_in_the_background_is_waited_for_not_compiled_twice(tmp_path, monkeypatch):
    """An urgent background compile (a real process), then the same library asked for at once:
    the caller waits for that process's library instead of running the compiler itself."""
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path))
    lib = build.library_in_background("tiny", _TINY, urgent=True)
    assert build.pending(lib) or lib.exists()
    before = build.compilations()
    assert build.library("tiny", _TINY) == lib and lib.exists()
    assert build.compilations() == before  # not compiled by this process
    assert not build.pending(lib) and not list(tmp_path.glob("*.staged"))


def test_a_background_compiler_that_died_is_not_waited_for(tmp_path, monkeypatch):
    """A staged directory whose compiler was killed outright (its lock file held by nobody) is
    not a compile in progress: the library is compiled by the caller."""
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path))
    lib = build.library_path("tiny", _TINY)
    staged = tmp_path / f"{lib.stem}.dead.staged"
    staged.mkdir()
    (staged / build.ALIVE).write_text("")
    assert not build.pending(lib)
    before = build.compilations()
    assert build.library("tiny", _TINY) == lib and build.compilations() == before + 1


def test_a_mapped_function_lives_as_long_as_the_function_it_maps():
    """functions.mapped_function keeps f.map(m) exactly as long as f: the map evaluates f column
    by column (checked against f itself) and goes when f goes."""
    import gc
    import weakref

    import casadi as ca

    from rrr4 import functions
    x = ca.SX.sym("x", 2)
    f = ca.Function("f", [x], [ca.vertcat(ca.sin(x[0]) * x[1], x[0] ** 2)])
    cols = np.array([[0.1, 0.5, -1.0], [2.0, -3.0, 0.25]])
    mapped = np.array(functions.mapped_function(f, 3)(cols))
    assert np.array_equal(mapped, np.column_stack([np.array(f(cols[:, j])).ravel() for j in range(3)]))
    kept = weakref.ref(functions.mapped_function(f, 3))
    assert functions.mapped_function(f, 3) is kept()  # built once
    del f
    gc.collect()
    assert kept() is None  # gone with f

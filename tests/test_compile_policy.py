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
from rrr4.codegen import build, policy
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
    monkeypatch.setattr(policy, "FIRST_VM_PER_BYTE", 1.0)  # as if its compile paid within the run
    started = []
    monkeypatch.setattr(build, "spawn", lambda args, alive: started.append(args))
    rows = []

    def sink(k0, kept):
        rows.append(kept.copy())
        if k0 == 2 and started:  # after the second block: the staged sources compiled now
            build.compile_staged(*started[0])

    run = _frames(method(jit=BACKGROUND), oscillator(3.0), sink=sink)
    assert len(started) == 1 and run.stats["stepping"]["compiled"] is True
    assert run.stats["stepping"]["compiled_from_frame"] == 4
    assert not list(tmp_path.glob("*.staged"))  # the staging directory is gone
    mixed = np.vstack(rows)
    vm = _frames(method(jit=False), oscillator(3.0)).states
    compiled = _frames(method(jit=True), oscillator(3.0)).states
    assert np.array_equal(mixed, vm) and np.array_equal(mixed, compiled)


def test_a_run_that_ends_first_leaves_the_library_for_the_next(tmp_path, monkeypatch):
    """A real background compiler: the first run steps in the virtual machine to its end (it
    never waits), a process of its own compiles the library, and a later run steps in it."""
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path))
    monkeypatch.setattr(policy, "FIRST_VM_PER_BYTE", 1.0)  # as if it paid within the run: compiled at NICE
    first = _frames(RK4(jit=BACKGROUND), oscillator(5.0))
    assert first.stats["stepping"]["compiled"] is False or first.stats["stepping"]["compiled_from_frame"] > 0
    for _ in range(3000):  # the compiler runs in its own process, niced: wait for its library
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
    assert fresh.stdout.strip() == ("{'compiled': True, 'compiled_from_frame': None, 'decision': 'compiled C from "
                                    "the cache'}")
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
    """A run too short for its compile to pay steps in the virtual machine and starts no compiler;
    its stepping record (summary.json's 'stepping') says so, with the estimates."""
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path))
    started = []
    monkeypatch.setattr(build, "spawn", lambda args, alive: started.append(args))
    sim = rrr4.simulate(rrr4.load_scene(Path(__file__).resolve().parents[1] / "problems" / "ideal_circle.yaml"),
                        t_end=0.01, jit=BACKGROUND)
    assert sim.stats["jit"] == BACKGROUND and not started and not list(tmp_path.glob("*.staged"))
    s = sim.stats["stepping"]
    assert s["compiled"] is False and s["compiled_from_frame"] is None and s["compiled_from_s"] is None
    assert s["decision"].startswith("not compiled (") and "would save" in s["decision"]
    from rrr4.results.metrics import stepping_text
    assert stepping_text(sim) == f"virtual machine; {s['decision']}"


def test_the_policy_compiles_what_pays_back_within_its_runs(tmp_path, monkeypatch):
    """With this machine's compile rate and a library's stepping costs remembered, a compile is
    decided exactly when PAYBACK_RUNS runs save its estimated time: the break-even run length,
    computed here by hand, separates the two decisions."""
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path))
    policy.remember_compile(100_000, "-O3", 2.0)  # 2e-5 s per byte
    policy.remember_stepping("frame_x.so", "vm", 3e-4)
    policy.remember_stepping("frame_x.so", "compiled", 1e-4)
    nbytes = 500_000  # 10 s of compiling; break-even at 10 / (PAYBACK_RUNS * 2e-4) steps
    PAYBACK = policy.PAYBACK_RUNS
    even = 10.0 / (PAYBACK * 2e-4)
    short, long = policy.decide("frame_x.so", nbytes, int(even * 0.9)), policy.decide("frame_x.so", nbytes,
                                                                                     int(even * 1.1))
    assert not short.compile and long.compile and long.level == "-O3"
    # it pays within this run only when one run saves the compile: then the run moves to it, else later runs do
    assert not long.now and "for later runs" in long.text()
    assert policy.decide("frame_x.so", nbytes, int(even * PAYBACK * 1.01)).now
    assert long.compile_s == pytest.approx(10.0) and long.vm_s == pytest.approx(int(even * 1.1) * 3e-4)
    # runs too short to pay, again and again: compiled once their losses in the VM add up to it
    lost = 0.0
    while not policy.decide("frame_x.so", nbytes, int(even * 0.1)).compile:
        policy.remember_stepping("frame_x.so", "vm", 3e-4, int(even * 0.1) * 3e-4)
        lost += int(even * 0.1) * 2e-4
    short_gain = PAYBACK * int(even * 0.1) * 2e-4  # what the payback runs of one short run would save
    assert 10.0 - short_gain - 1e-9 <= lost < 10.0 - short_gain + int(even * 0.1) * 2e-4 + 1e-9
    # another machine (CPU) shares nothing of it
    from rrr4.codegen import host
    monkeypatch.setattr(policy, "cpu", lambda: "another CPU")
    assert host.cpu() != "another CPU"
    assert policy.decide("frame_x.so", nbytes, 1).compile_s == pytest.approx(nbytes * policy.FIRST_COMPILE["-O3"])


def test_the_level_follows_the_source_size():
    """-O3 up to O3_MAX_BYTES, -O1 up to O1_MAX_BYTES, -O0 up to O0_MAX_BYTES, nothing beyond;
    the flags (and so the library's key) of a large source carry -O1, those of a small one the
    project's flags."""
    assert policy.level(policy.O3_MAX_BYTES) == "-O3" and policy.level(policy.O3_MAX_BYTES + 1) == "-O1"
    assert policy.level(policy.O1_MAX_BYTES + 1) == "-O0" and policy.level(policy.O0_MAX_BYTES + 1) is None
    assert build.flags_for({"a.c": "x"}) == tuple(build.COMPILE_FLAGS)
    big = build.flags_for({"a.c": "x" * (policy.O3_MAX_BYTES + 1)})
    assert "-O1" in big and "-O3" not in big


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


def test_a_compile_for_later_runs_waits_for_the_run_that_asked_for_it(tmp_path, monkeypatch):
    """A background compile that serves later runs only (later=True) does not start while the
    process that asked for it lives; that process, asking for the library itself meanwhile,
    compiles it instead of waiting (no deadlock)."""
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path))
    lib = build.library_in_background("tiny", _TINY, later=True)
    time.sleep(2.0)
    assert not lib.exists() and list(tmp_path.glob("*.staged"))  # its compiler waits for us
    assert not build.pending(lib)  # not for this process to wait for
    before = build.compilations()
    assert build.library("tiny", _TINY) == lib and build.compilations() == before + 1

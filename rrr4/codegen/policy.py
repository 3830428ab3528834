"""Whether compiling a stepping library pays, and at which -O level: the estimates behind the
default compile policy ('background', :func:`rrr4.simulation.default_jit`) and what this
machine has measured.

- **The -O level** (:func:`level`) follows the size of the C source, so that no generated file
  keeps the compiler busy for more than about a minute on one core: -O3 up to
  :data:`O3_MAX_BYTES`, -O1 up to :data:`O1_MAX_BYTES`, -O0 up to :data:`O0_MAX_BYTES`, a
  larger source not at all by the policy (forced with ``RRR4_JIT=1``, at -O0). The wear scene's
  frames (4.8 MB of C) took 99 s of one core at -O1 and 19 s at -O0 (over 114 s at -O3,
  ``benchmarks/bench_compile_time.py``). Measured on the reference scene
  (``benchmarks/bench_opt_level.py``): -O1 compiles 1.8x faster than -O3 and steps 1.7x
  slower (still 7.7x faster than the virtual machine); -O2 compiles and steps as -O3 does.
  The level depends on the size alone, so a library's cache key does not move between runs.
- **Compile time** [s of one core]: the source's size times this machine's seconds per byte at
  that level, the median of its last compiles (:func:`remember_compile`), or before any
  :data:`FIRST_COMPILE` (``benchmarks/bench_compile_time.py``).
- **Stepping time** of a run: its steps times the seconds per step of this library in the
  virtual machine and compiled, as this machine last measured them (:func:`remember_stepping`),
  or before any, a first estimate from the expression's size (its C source):
  :data:`FIRST_VM_PER_BYTE` seconds per byte and step in the virtual machine,
  :data:`FIRST_SPEEDUP` times faster compiled.
- **The decision** (:func:`decide`): compile (in the background, while the virtual machine
  steps) when the stepping time it saves over :data:`PAYBACK_RUNS` runs of this length, plus
  what the runs of this library have already lost stepping in the virtual machine on this
  machine, covers the compile time; else step in the virtual machine and compile nothing. So
  many short runs alike (a sweep's cases, a test) end up compiled once their losses add up to
  the compile (the rent-or-buy rule, never worse than twice the best choice in hindsight).

The measurements live in ``costs.json`` in the compile cache (:func:`rrr4.codegen.host.cache_dir`),
one section per CPU (:func:`rrr4.codegen.host.cpu`), written atomically under a lock.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import statistics
import tempfile
from dataclasses import dataclass
from pathlib import Path

from .host import cache_dir, cpu

__all__ = ["Decision", "decide", "level", "remember_compile", "remember_stepping", "estimated_compile",
           "O3_MAX_BYTES", "O1_MAX_BYTES", "O0_MAX_BYTES", "PAYBACK_RUNS", "FIRST_COMPILE", "FIRST_VM_PER_BYTE",
           "FIRST_SPEEDUP"]

# [s of one core per byte of C] at each level, before this machine has measured its own: the
# reference scene's frames and controllers (0.2-0.6 MB), benchmarks/bench_compile_time.py
# (-O1 and -O0: the wear scene's frames, 4.8 MB: 99 s and 19 s; -O3 over 114 s, stopped there)
FIRST_COMPILE = {"-O3": 1.6e-5, "-O1": 2e-5, "-O0": 4e-6}
O3_MAX_BYTES = 1_500_000  # about 25 s at -O3 by FIRST_COMPILE
O1_MAX_BYTES = 2_500_000  # about 50 s at -O1
O0_MAX_BYTES = 12_000_000  # about 50 s at -O0
# [s per step and byte of C] in the virtual machine, and how many times faster compiled stepping
# is: the reference scene's frame (0.6 MB of C; 1 s at 1e-4 s: 3.8 s in the VM, 0.30 s at -O3,
# on a loaded machine, benchmarks/bench_opt_level.py)
FIRST_VM_PER_BYTE = 3e-10
FIRST_SPEEDUP = 10.0
PAYBACK_RUNS = 10  # a compile pays when it saves its own time within this many runs alike
KEEP = 20  # compiles remembered per level
STEPPING = 200  # libraries whose stepping is remembered


def level(nbytes: int) -> str | None:
    """The -O level a C source of `nbytes` bytes is compiled at (None: too large for the
    policy to compile, see the module docstring)."""
    for lv, most in (("-O3", O3_MAX_BYTES), ("-O1", O1_MAX_BYTES), ("-O0", O0_MAX_BYTES)):
        if nbytes <= most:
            return lv
    return None


@dataclass(frozen=True)
class Decision:
    """What the policy decided for one library and run, and the estimates it decided on [s]."""
    compile: bool
    level: str | None
    source_bytes: int
    compile_s: float  # the compiler, one core
    vm_s: float  # this run's stepping in the virtual machine
    compiled_s: float  # and compiled

    @property
    def now(self) -> bool:
        """Whether the compile pays within this run (then the run moves to the library when it
        is ready); otherwise it serves later runs only, and its compiler takes the least of the
        machine (:data:`rrr4.codegen.build.NICE_LATER`)."""
        return self.compile and self.vm_s - self.compiled_s >= self.compile_s

    def reason(self) -> str:
        """The estimates behind it, in words."""
        mb, gain = self.source_bytes / 1e6, max(self.vm_s - self.compiled_s, 0.0)
        if self.level is None:
            return f"{mb:.2f} MB of C: too large to compile within a minute"
        return (f"{mb:.2f} MB of C at {self.level}: about {self.compile_s:.0f} s of compiling "
                f"{'to save' if self.compile else 'would save'} about {gain:.2g} s per run like this"
                + ("" if self.compile else f", less than {PAYBACK_RUNS} runs repay"))

    def text(self) -> str:
        """One line for the user and summary.json."""
        what = ("compiled in the background" + ("" if self.now else " for later runs") if self.compile else
                "not compiled")
        return f"{what} ({self.reason()})"


def decide(name: str, nbytes: int, steps: int) -> Decision:
    """Whether the library `name` (its file name in the cache), from `nbytes` of C, pays for
    its compile over a run of `steps` steps (see the module docstring)."""
    lv = level(nbytes)
    costs = _read()
    compile_s = nbytes * _rate(costs, lv or "-O0")
    per_step = costs.get("stepping", {}).get(name, {})
    vm = per_step.get("vm") or nbytes * FIRST_VM_PER_BYTE
    compiled = per_step.get("compiled") or vm / FIRST_SPEEDUP
    vm_s, compiled_s = steps * vm, steps * min(compiled, vm)
    lost = per_step.get("vm_spent", 0.0) * (1.0 - min(compiled, vm) / vm)  # by the earlier runs in the VM
    pays = lv is not None and PAYBACK_RUNS * (vm_s - compiled_s) + lost >= compile_s
    return Decision(pays, lv, nbytes, compile_s, vm_s, compiled_s)


def estimated_compile(nbytes: int) -> float:
    """Seconds of one core the compiler is estimated to take on `nbytes` of C at its level."""
    return nbytes * _rate(_read(), level(nbytes) or "-O0")


def remember_compile(nbytes: int, lv: str, seconds: float) -> None:
    """Record that `nbytes` of C took `seconds` of the compiler's CPU time at level `lv`."""
    def put(c):
        seen = c.setdefault("compile", {}).setdefault(lv, [])
        seen.append(seconds / nbytes)
        del seen[:-KEEP]
    if nbytes > 0 and seconds > 0 and lv in FIRST_COMPILE:
        _update(put)


def remember_stepping(name: str, how: str, seconds_per_step: float, seconds: float = 0.0) -> None:
    """Record the seconds per step the library `name` took stepping in the virtual machine
    (`how` 'vm') or compiled ('compiled'), and (virtual machine) the `seconds` it stepped there."""
    def put(c):
        table = c.setdefault("stepping", {})
        entry = table.setdefault(name, {})
        entry[how] = seconds_per_step
        if how == "vm":
            entry["vm_spent"] = entry.get("vm_spent", 0.0) + seconds
        for old in list(table)[:-STEPPING]:
            del table[old]
    if seconds_per_step > 0:
        _update(put)


def _rate(costs: dict, lv: str) -> float:
    seen = costs.get("compile", {}).get(lv)
    return statistics.median(seen) if seen else FIRST_COMPILE[lv]


def _file() -> Path:
    return cache_dir() / "costs.json"


def _section() -> str:
    return hashlib.sha256(cpu().encode()).hexdigest()[:16]


def _read() -> dict:
    with contextlib.suppress(OSError, ValueError):
        data = json.loads(_file().read_text())
        if isinstance(data, dict) and isinstance(data.get(_section()), dict):
            return data[_section()]
    return {}


def _update(change) -> None:
    """Apply change(costs of this CPU) to the file, under its lock, replaced atomically."""
    path = _file()
    with open(path.with_suffix(".lock"), "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        data = {}
        with contextlib.suppress(OSError, ValueError):
            data = json.loads(path.read_text())
        if not isinstance(data, dict):
            data = {}
        section = data.setdefault(_section(), {})
        change(section)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".costs.", suffix=".tmp")
        with os.fdopen(fd, "w") as f:
            json.dump(data, f)
        os.replace(tmp, path)

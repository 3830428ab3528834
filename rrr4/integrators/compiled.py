"""Compiled CasADi Functions, cached on disk by the hash of their generated C.

:func:`compiled` generates C for a Function (CasADi's CodeGenerator), compiles it with the
system C compiler into a shared library and loads it with ``casadi.external``. The library
is named after the SHA-256 of the C source, the compiler flags and the CPU, so a second run
of the same scene and method finds it and does not recompile; a lock file per library makes
processes that need the same one at once (sweep workers) compile it once. The cache directory is
``$RRR4_CACHE`` if set, else ``~/.cache/rrr4``.

The code is compiled for the CPU it runs on (:data:`COMPILE_FLAGS`: ``-O3 -march=native``),
with floating-point contraction off and ``errno`` ignored by the math functions, so that it
computes bit for bit what ``-O2`` code computes, only faster; ``-fno-semantic-interposition``
lets the compiler inline CasADi's small helpers (``casadi_sq``, ``casadi_fmax``,
``casadi_norm_inf``, ...), which a shared library otherwise calls through its procedure
linkage table. Together 1.5x on the reference scene's stepping (``benchmarks/bench_flags.py``).
Because the library is specific to the CPU, the CPU is part of its key: a cache shared by
different machines keeps one library per CPU. A compiler that refuses these flags compiles
with :data:`PORTABLE_FLAGS` instead.
"""

from __future__ import annotations

import fcntl
import functools
import hashlib
import os
import platform
import tempfile
from pathlib import Path

import casadi as ca

from ..files import BuildError, run_c_compiler

__all__ = ["compiled", "cache_dir", "compilations", "COMPILE_FLAGS", "PORTABLE_FLAGS"]

PORTABLE_FLAGS = ("-O2", "-fPIC", "-shared")
COMPILE_FLAGS = ("-O3", "-march=native", "-ffp-contract=off", "-fno-math-errno", "-fno-semantic-interposition",
                 "-fPIC", "-shared")
_loaded: dict[str, ca.Function] = {}
_compilations = [0]  # libraries this process built (not found in the cache)


def compilations() -> int:
    """How many libraries this process has compiled (cache hits excluded)."""
    return _compilations[0]


def cache_dir() -> Path:
    """Directory of the compiled libraries (created if needed)."""
    d = Path(os.environ.get("RRR4_CACHE") or Path.home() / ".cache" / "rrr4")
    d.mkdir(parents=True, exist_ok=True)
    return d


@functools.cache
def cpu() -> str:
    """What identifies this machine's CPU for -march=native: the model and feature flags of
    its first processor (Linux), else what the platform module knows."""
    try:
        with open("/proc/cpuinfo") as fh:
            first = fh.read().split("\n\n")[0]
        keep = [line for line in first.splitlines() if line.split(":")[0].strip() in ("vendor_id", "model name",
                                                                                    "flags", "Features", "CPU part")]
        if keep:
            return "\n".join(keep)
    except OSError:
        pass
    return f"{platform.machine()} {platform.processor()}"


def compiled(f: ca.Function, sources=()) -> ca.Function:
    """`f` as a compiled external Function with the same name and I/O (cached on disk and in memory).

    sources: further C files compiled into the same library, e.g. the generated code of an
    external Function that `f` calls (their text is part of the cache key).

    Raises BuildError (an Rrr4Error) if no C compiler ($CC, cc or gcc) is available or
    compilation fails.
    """
    cg = ca.CodeGenerator(f"{f.name()}.c", {"with_header": False})
    cg.add(f)
    src = cg.dump()
    extra = [Path(p).resolve() for p in sources]
    key = hashlib.sha256("\n".join([src, " ".join(COMPILE_FLAGS), cpu(), *(p.read_text() for p in extra)]
                                   ).encode()).hexdigest()[:24]
    if key in _loaded:
        return _loaded[key]
    lib = cache_dir() / f"{f.name()}_{key}.so"
    if not lib.exists():
        # one compiler per library: a process (e.g. another sweep worker) that needs the same
        # library waits for it instead of compiling it again
        with open(lib.with_suffix(".lock"), "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if not lib.exists():
                with tempfile.TemporaryDirectory(dir=lib.parent) as tmp:
                    c_file = Path(tmp) / f"{f.name()}.c"
                    c_file.write_text(src)
                    tmp_lib = Path(tmp) / lib.name
                    files = [str(c_file), *map(str, extra), "-o", str(tmp_lib), "-lm"]
                    try:
                        run_c_compiler([*COMPILE_FLAGS, *files], tmp)
                    except BuildError:  # e.g. a compiler without -march=native: the same code, portable
                        run_c_compiler([*PORTABLE_FLAGS, *files], tmp)
                    os.replace(tmp_lib, lib)  # atomic: never a half-written cache entry
                _compilations[0] += 1
    ext = ca.external(f.name(), str(lib))
    _loaded[key] = ext
    return ext

"""Compiled CasADi Functions, cached on disk by the hash of their generated C.

:func:`compiled` generates C for a Function (CasADi's CodeGenerator), compiles it with the
system C compiler into a shared library and loads it with ``casadi.external``. The library
is named after the SHA-256 of the C source (and the compiler flags), so a second run of
the same scene and method finds it and does not recompile; a lock file per library makes
processes that need the same one at once (sweep workers) compile it once. The cache directory is
``$RRR4_CACHE`` if set, else ``~/.cache/rrr4``.
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import tempfile
from pathlib import Path

import casadi as ca

from ..files import run_c_compiler

__all__ = ["compiled", "cache_dir", "compilations", "COMPILE_FLAGS"]

COMPILE_FLAGS = ("-O2", "-fPIC", "-shared")
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
    key = hashlib.sha256("\n".join([src, " ".join(COMPILE_FLAGS), *(p.read_text() for p in extra)]).encode()
                         ).hexdigest()[:24]
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
                    run_c_compiler([*COMPILE_FLAGS, str(c_file), *map(str, extra), "-o", str(tmp_lib), "-lm"], tmp)
                    os.replace(tmp_lib, lib)  # atomic: never a half-written cache entry
                _compilations[0] += 1
    ext = ca.external(f.name(), str(lib))
    _loaded[key] = ext
    return ext

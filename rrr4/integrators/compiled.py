"""Compiled stepping: a CasADi Function as generated C, compiled and loaded back.

:func:`compiled` generates C for a Function (CasADi's CodeGenerator) and hands it to
:func:`rrr4.codegen.build.library`, the one on-disk cache of compiled libraries (named after
the hash of the C, the compiler flags and the CPU; a lock per library, so sweep workers that
need the same one compile it once; ``-O3 -march=native`` with a portable fallback), then
loads it with ``casadi.external``. A second run of the same scene and method finds the
library and does not recompile. :func:`compilations` counts the libraries this process built.

CasADi's ``casadi_fmax`` and ``casadi_fmin`` call the C library's ``fmax``/``fmin``, which no
compiler inlines without ``-ffinite-math-only`` (that would drop their NaN rule). The contact
and friction laws use about 90 of them per right-hand side, 6 % of the reference scene's
stepping. :func:`inline_min_max` rewrites their bodies as the same rule written out: the
larger (smaller) operand, compared as x86's ``maxsd``/``minsd`` and glibc compare, and the
other operand where one is NaN; so the stepping computes the same numbers bit for bit
(``benchmarks/bench_flags.py`` checks it and times both). That is glibc's rule on x86-64
only (elsewhere +0 may rank above -0), so only there is the rewrite made
(:data:`INLINE_MIN_MAX`). Computing each angle's sine and cosine by one ``sincos`` call,
which the compiler does only in some functions, was measured too (bit for bit the same with
glibc) and bought 0.4 %: not done.
"""

from __future__ import annotations

import platform
from pathlib import Path

import casadi as ca

from ..codegen.build import compilations, library, library_in_background, library_path, load, say, source_bytes
from ..codegen.policy import decide
from ..codegen.policy import remember_stepping as remember

__all__ = ["compiled", "compiled_later", "compilations", "inline_min_max", "load"]

# read at call time (benchmarks/bench_flags.py swaps it): the rule below is glibc's x86-64
# fmax/fmin (maxsd/minsd: the second operand when both are zeros); aarch64's glibc (fmaxnm) and
# other C libraries order +0 above -0, so elsewhere the library is called as CasADi writes it
INLINE_MIN_MAX = platform.machine().lower() in ("x86_64", "amd64") and platform.libc_ver()[0] == "glibc"
# C99 fmax/fmin: the other operand where one is NaN (NaN only if both are); else x > y ? x : y
# (x < y ? x : y), which is what glibc's maxsd (minsd) returns for +0 and -0 as well
_MIN_MAX = {"  return fmax(x, y);": "  return x > y ? x : (y != y ? x : y);",
            "  return fmin(x, y);": "  return x < y ? x : (y != y ? x : y);"}


def compiled(f: ca.Function, sources=()) -> ca.Function:
    """`f` as a compiled external Function with the same name and I/O (cached on disk and in memory).

    sources: further C files compiled into the same library, e.g. the generated code of an
    external Function that `f` calls (their text is part of the cache key).

    Raises BuildError (an Rrr4Error) if no C compiler ($CC, cc or gcc) is available or
    compilation fails.
    """
    return load(f.name(), library(f.name(), _sources(f), extra=sources))


def compiled_later(f: ca.Function, sources=(), steps: int = 0) -> tuple[ca.Function | None, Path, bool, str]:
    """(`f` compiled, as :func:`compiled`, if its library is in the cache, else None; the
    library's path; whether a process of its own compiles it now; what was decided, in words).
    A library not yet cached is compiled by a process of its own
    (:func:`rrr4.codegen.build.library_in_background`) while the caller goes on, e.g. stepping
    in CasADi's virtual machine (``load(f.name(), path)`` once ``path.exists()``), if that pays
    over a run of `steps` steps (:func:`rrr4.codegen.policy.decide`); otherwise nothing is
    compiled."""
    text = _sources(f)
    lib = library_path(f.name(), text, sources)
    if lib.exists():
        return load(f.name(), lib), lib, False, "compiled C from the cache"
    decision = decide(lib.name, source_bytes(text) + sum(Path(p).stat().st_size for p in sources), steps)
    if not decision.compile:
        say(f"{f.name()}: CasADi's virtual machine steps it, {decision.text()}")
        return None, lib, False, decision.text()
    library_in_background(f.name(), text, extra=sources, about=decision.reason(), later=not decision.now)
    return (load(f.name(), lib) if lib.exists() else None), lib, not lib.exists(), decision.text()


def remember_stepping(lib: Path, timed: dict) -> None:
    """Record the seconds per step the library `lib` (see :func:`compiled_later`) took in the
    virtual machine (timed[False]) and compiled (timed[True]), each [seconds, steps], for the
    compile policy's next estimate (:func:`rrr4.codegen.policy.remember_stepping`); a short
    stretch (under 0.2 s) is not a measurement."""
    for compiled_c, (seconds, steps) in timed.items():
        if steps and seconds > 0.2:
            remember(lib.name, "compiled" if compiled_c else "vm", seconds / steps, seconds)


def _sources(f: ca.Function) -> dict[str, str]:
    cg = ca.CodeGenerator(f"{f.name()}.c", {"with_header": False})
    cg.add(f)
    return {f"{f.name()}.c": inline_min_max(cg.dump()) if INLINE_MIN_MAX else cg.dump()}


def inline_min_max(text: str) -> str:
    """CasADi's generated C with ``casadi_fmax``/``casadi_fmin`` computing C99's fmax/fmin inline
    instead of calling the C library (see the module docstring)."""
    for call, inline in _MIN_MAX.items():
        text = text.replace(call, inline)
    return text

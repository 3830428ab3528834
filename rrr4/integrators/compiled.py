"""Compiled stepping: a CasADi Function as generated C, compiled and loaded back.

:func:`compiled` generates C for a Function (CasADi's CodeGenerator) and hands it to
:func:`rrr4.codegen.build.library`, the one on-disk cache of compiled libraries (named after
the hash of the C, the compiler flags and the CPU; a lock per library, so sweep workers that
need the same one compile it once; ``-O3 -march=native`` with a portable fallback), then
loads it with ``casadi.external``. A second run of the same scene and method finds the
library and does not recompile. :func:`compilations` counts the libraries this process built.
"""

from __future__ import annotations

import casadi as ca

from ..codegen.build import compilations, library, load

__all__ = ["compiled", "compilations"]


def compiled(f: ca.Function, sources=()) -> ca.Function:
    """`f` as a compiled external Function with the same name and I/O (cached on disk and in memory).

    sources: further C files compiled into the same library, e.g. the generated code of an
    external Function that `f` calls (their text is part of the cache key).

    Raises BuildError (an Rrr4Error) if no C compiler ($CC, cc or gcc) is available or
    compilation fails.
    """
    cg = ca.CodeGenerator(f"{f.name()}.c", {"with_header": False})
    cg.add(f)
    return load(f.name(), library(f.name(), {f"{f.name()}.c": cg.dump()}, extra=sources))

"""Self-contained C for controllers: generate, compile with gcc, load back into CasADi.

``codegen(scene, out_dir)`` writes, for one scene with a task body and actuators (a
closed-form 4-RRR: every kernel of :data:`KERNELS`; any other scene, a graph included:
the path and the controller step, :data:`STEP_KERNELS`, see :mod:`.kernels`):

- ``rrr4_raw.c`` / ``rrr4_raw.h``: CasADi's generated code, one ``rrr4_raw_<kernel>``
  per kernel in CasADi's calling convention (``arg, res, iw, w, mem``);
- ``rrr4.h`` / ``rrr4.c``: plain wrappers ``rrr4_<kernel>(inputs..., outputs...)`` on
  double arrays, documented with shapes and units, with their work arrays on the stack
  (no allocation, re-entrant);
- ``main.c``: an example controller loop along the scene's path; ``Makefile``.

Nothing needs CasADi at build or run time: ``gcc -O2 -Wall *.c -lm`` builds the example.
The package, one idea per module:

- :mod:`.kernels`: the Functions generated (:data:`KERNELS`), built once per problem by
  calling the problem's own Functions symbolically, so the C computes exactly what the
  Python does; the exact preload's branch (:func:`preload_branch`);
- :mod:`.text`: the C text around them (wrapper header and source with the parameter docs,
  the example ``main.c``, the ``Makefile``);
- :mod:`.build`: the one on-disk cache of compiled shared libraries (lock per library, CPU
  in the key, fast flags with a portable fallback), used here by :func:`generated_controller`
  and by the compiled stepping (:mod:`rrr4.integrators.compiled`);
- here: the front door :func:`codegen`, and building and loading its output
  (:func:`compile_library`, :func:`build_example`, :func:`load_library`).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import casadi as ca

from ..errors import SceneError
from ..files import BuildError, atomic_directory, run_c_compiler
from ..problem import Problem
from ..scene import Scene
from . import build
from .kernels import KERNELS, RAW, STEP_KERNELS, WRAPPER, Kernel, kernels, preload_branch
from .text import EXAMPLE_ANGLE_OFFSET, texts

__all__ = ["codegen", "kernels", "generated_controller", "start_generated_controller",
           "preload_branch", "compile_library", "build_example",
           "load_library", "Kernel", "KERNELS", "STEP_KERNELS", "EXAMPLE_ANGLE_OFFSET", "BuildError"]


CONTROLLER_LEVEL = "-O1"  # the generated controller's own library (see generated_controller)


# ----------------------------------------------------------------------------- files

def _out_dir(out_dir) -> Path:
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise SceneError(f"--out: {str(out)!r} is a file (expected a directory to write C sources into)")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise SceneError(f"--out: cannot create {str(out)!r} ({e.strerror})") from None
    return out


def codegen(scene: Scene | Problem, out_dir, branch="auto") -> list[Path]:
    """Write the scene's controller C into out_dir (created if needed); return the files.

    Files: rrr4_raw.c, rrr4_raw.h (CasADi), rrr4.h, rrr4.c (wrappers), main.c, Makefile.
    The directory is written atomically (:func:`rrr4.files.atomic_directory`): out_dir must
    be new, empty or an earlier codegen output (holds rrr4.h), which is replaced whole, so an
    interrupted run leaves the earlier files intact. branch: the exact_preload and preload
    kernels' branch (:func:`preload_branch`); a fixed one keeps the torques continuous along a
    path; 'auto' only for a scene without those kernels. The controller step is the one
    :func:`rrr4.simulate` runs with its generated controller
    (:func:`rrr4.control.controller_step`), with the scene's preload sign
    (:func:`rrr4.preload.preload_sign`). Raises SceneError for a scene without a task body or
    actuators (no controller), before anything is written.
    """
    problem = Problem.from_scene(scene)
    given, branch = branch, preload_branch(problem, branch)
    ks = kernels(problem, branch)
    if given != "auto" and len(ks) == len(STEP_KERNELS):
        raise SceneError(f"branch: {given!r} is not allowed for scene {problem.name!r} (it chooses the branch of a "
                         "4-RRR's exact_preload and preload functions; this scene's C has the controller step only, "
                         "on the scene's own preload sign: use auto)")
    out = _out_dir(out_dir)
    cg = ca.CodeGenerator(f"{RAW}.c", {"with_header": True})
    for k in ks:
        cg.add(k.function)

    def fill(tmp: Path) -> None:
        cg.generate(str(tmp) + os.sep)
        for name, text in texts(problem, ks, branch).items():
            (tmp / name).write_text(text)

    atomic_directory(out, fill, marker=f"{WRAPPER}.h")
    return [out / name for name in (f"{RAW}.c", f"{RAW}.h", f"{WRAPPER}.h", f"{WRAPPER}.c", "main.c", "Makefile")]


# ----------------------------------------------------------------------------- build and load

def compile_library(src_dir, lib_path, flags=("-O2", "-Wall", "-Werror")) -> Path:
    """Compile rrr4_raw.c and rrr4.c of src_dir into the shared library lib_path; return it.

    Raises BuildError on any compiler error or warning.
    """
    src, lib = Path(src_dir).resolve(), Path(lib_path).resolve()
    run_c_compiler([*flags, "-fPIC", "-shared", f"{RAW}.c", f"{WRAPPER}.c", "-lm", "-o", str(lib)], src,
                   warnings_are_errors=True)
    return lib


def build_example(src_dir, exe_path, flags=("-O2", "-Wall", "-Werror")) -> Path:
    """Compile every .c of src_dir (the example) into exe_path; return it."""
    src, exe = Path(src_dir).resolve(), Path(exe_path).resolve()
    run_c_compiler([*flags, *sorted(p.name for p in src.glob("*.c")), "-lm", "-o", str(exe)], src,
                   warnings_are_errors=True)
    return exe


def generated_controller(problem: Problem) -> tuple[ca.Function, Path]:
    """The scene's controller step as :func:`codegen` writes it, compiled with the C compiler
    and loaded with ``casadi.external`` ('rrr4_raw_controller_step', same inputs and outputs
    as :func:`rrr4.control.controller_step`), and the path of its C source. Cached on disk
    (:func:`rrr4.codegen.build.library`, stem 'controller') by the hash of the generated C;
    the sources stay beside the library, since the compiled stepping compiles rrr4_raw.c in
    (at the frame's level). This library serves the virtual machine's stepping until the
    frame's own is compiled, and a run waits for it: it is compiled at
    :data:`CONTROLLER_LEVEL`, which compiles it 2.2x faster than -O3 (1.3 against 2.9 s of one
    core on the reference scene, ``benchmarks/bench_compile_time.py``), the same numbers. A
    compile started by :func:`start_generated_controller` is waited for."""
    lib = build.library("controller", _controller_sources(problem), keep_sources=True, level=CONTROLLER_LEVEL)
    return build.load(f"{RAW}_controller_step", lib), lib.with_suffix("") / f"{RAW}.c"


def start_generated_controller(problem: Problem) -> Path:
    """Start compiling :func:`generated_controller`'s library in a process of its own
    (:func:`rrr4.codegen.build.library_in_background`, urgent: at once) unless it is cached,
    so that a caller with other work first (a study's other arms) finds it compiled, or
    nearly, when it asks for it; the library's path."""
    return build.library_in_background("controller", _controller_sources(problem), keep_sources=True, urgent=True,
                                       level=CONTROLLER_LEVEL)


def _controller_sources(problem: Problem) -> dict[str, str]:
    """The C text of the scene's controller (:func:`codegen`'s files but main.c and the
    Makefile), generated once per problem."""
    def generate() -> dict[str, str]:
        with tempfile.TemporaryDirectory() as tmp:
            src = Path(tmp) / "src"
            codegen(problem, src)
            return {name: (src / name).read_text() for name in (f"{RAW}.c", f"{RAW}.h", f"{WRAPPER}.h",
                                                                 f"{WRAPPER}.c")}
    return problem.memo(("controller_sources",), generate)


def load_library(lib_path, names=KERNELS) -> dict[str, ca.Function]:
    """The compiled kernels as CasADi Functions (``casadi.external``), keyed by kernel name."""
    lib = str(Path(lib_path).resolve())
    return {k: ca.external(f"{RAW}_{k}", lib) for k in names}


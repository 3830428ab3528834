"""Self-contained C for controllers: generate, compile with gcc, load back into CasADi.

``codegen(scene, out_dir)`` writes, for one scene:

- ``rrr4_raw.c`` / ``rrr4_raw.h``: CasADi's generated code, one ``rrr4_raw_<kernel>``
  per kernel in CasADi's calling convention (``arg, res, iw, w, mem``);
- ``rrr4.h`` / ``rrr4.c``: plain wrappers ``rrr4_<kernel>(inputs..., outputs...)`` on
  double arrays, documented with shapes and units, with their work arrays on the stack
  (no allocation, re-entrant);
- ``main.c``: an example controller loop along the scene's path; ``Makefile``.

Nothing needs CasADi at build or run time: ``gcc -O2 -Wall *.c -lm`` builds the example.
Kernels (:data:`KERNELS`) are built once per scene by calling the model's own Functions
symbolically, so the C computes exactly what the Python does.

The exact preload law is exposed twice: ``exact_preload`` takes the affine reaction family
(tau_p, tau_n, r_p, r_n) and ``preload`` takes the desired motion (pose, pose_d, pose_dd).
A platform wrench alone does not fix the passive-joint reactions: they also carry the
inertia forces of every driving and following link, so the law needs the motion (or the
family computed from it by ``inverse_dynamics``).
"""

from __future__ import annotations

import functools
import os
import textwrap
from dataclasses import dataclass
from pathlib import Path

import casadi as ca

from .control import controller_function
from .errors import SceneError
from .files import BuildError, atomic_directory, run_c_compiler
from .preload.exact import exact_preload_function
from .preload.qp import qp_preload_function
from .preload.signs import preload_sign
from .problem import Problem
from .scene import Scene
from .trajectory import trajectory_function

__all__ = ["codegen", "kernels", "generated_controller", "preload_branch", "compile_library", "build_example",
           "load_library", "KERNELS", "BuildError"]

RAW = "rrr4_raw"  # stem of CasADi's generated .c/.h and prefix of its symbols
WRAPPER = "rrr4"  # stem of the wrapper .c/.h and prefix of the wrapper functions
KERNELS = ("ik", "jacobian", "null_space", "trajectory", "inverse_dynamics", "exact_preload", "preload",
           "controller_step", "qp_preload")

# What each input/output is, with units; shapes come from the Functions themselves.
_IO_DOC = {
    "t": "time since the start of the path [s]",
    "pose": "platform pose [x, y, theta_o] [m, m, rad]",
    "pose_d": "platform velocity [m/s, m/s, rad/s]",
    "pose_dd": "platform acceleration [m/s^2, m/s^2, rad/s^2]",
    "pose_des": "desired platform pose [x, y, theta_o] [m, m, rad]",
    "pose_d_des": "desired platform velocity [m/s, m/s, rad/s]",
    "pose_dd_des": "desired platform acceleration [m/s^2, m/s^2, rad/s^2]",
    "theta_ref": "actuator angle references [rad] (compensated for the journal seats if the scene says so)",
    "theta_d_ref": "actuator rate references [rad/s]",
    "theta": "actuator angles [rad]",
    "theta_d": "actuator rates [rad/s]",
    "cos_arg": "argument of acos per chain [-]; the pose is reachable iff all |cos_arg| <= 1",
    "J": "Jacobian, d theta = J d pose [rad/m, rad/m, rad/rad by column]",
    "sin_transmission": "sine of the angle between driving and following link [-] (0 = serial singularity)",
    "n": "unit null-space vector of J^T [-]: torques along n move nothing",
    "tau_p": "particular (minimum-norm) actuator torques [N m]",
    "tau_n": "null-space torque direction [-] (unit; tau = tau_p + alpha tau_n)",
    "r_p": "particular reactions at B1..B4, C1..C4, column j = [r_x, r_y] [N]",
    "r_n": "reactions per unit alpha at B1..B4, C1..C4 [N/(N m)]",
    "alpha": "preload along the null space [N m]",
    "tau": "actuator torques [N m]",
    "tau_ff": "feed-forward torques (inverse dynamics + preload (+ friction compensation)), before PD and "
              "clipping [N m]",
    "feasible": "[-] 1.0 if every passive joint carries >= min_force within the torque limits, else 0.0",
    "margin": "min_j |r_j| - min_force [N]",
}
_KERNEL_DOC = {
    "ik": "Inverse kinematics, closed form, in the scene's working modes.",
    "jacobian": "Jacobian of the actuator angles with respect to the platform pose.",
    "null_space": "Null space of J^T (the preload direction).",
    "trajectory": "The scene's desired path: pose and its derivatives at time t.",
    "inverse_dynamics": "Inverse dynamics of the ideal mechanism: the affine family tau = tau_p + alpha tau_n "
                        "and the passive reactions r_j = r_p[:, j] + alpha r_n[:, j] (force of the inboard on "
                        "the outboard body, global frame).",
    "exact_preload": "Exact preload law on a given reaction family: the least sum_i w_i tau_i^2 subject to "
                     "|r_j| >= min_force at all passive joints and |tau_i| <= limit_i, with alpha on the branch "
                     "RRR4_PRELOAD_BRANCH (closed form, no iterations).",
    "preload": "Exact preload law for a desired motion: inverse_dynamics followed by exact_preload.",
    "controller_step": "One controller step, the one rrr4.simulate runs: tau = clip(tau_ff + kp (theta_ref - "
                       "theta) + kd (theta_d_ref - theta_d), +-limit), the angle error wrapped to [-pi, pi); tau_ff "
                       "= inverse dynamics + the scene's preload (RRR4_PRELOAD_METHOD on RRR4_PRELOAD_SIGN); "
                       "theta_ref = ik(pose_des), or with RRR4_COMPENSATION clearance the IK closed around the "
                       "predicted journal seats, plus the torques that overcome their friction.",
    "qp_preload": "Preload as a QP (qrqp active set, no allocation): fixed-sign axial force >= min_force in "
                  "every following link, torque limits, least weighted effort. Returns non-zero, with the "
                  "outputs undefined, when qrqp stops without a solution (an infeasible QP).",
}



@dataclass(frozen=True)
class Kernel:
    """One generated function: ``name`` (C wrapper ``rrr4_<name>``), the CasADi Function
    ``rrr4_raw_<name>`` with dense inputs and outputs, and a one-line description."""
    name: str
    function: ca.Function
    doc: str


def _renamed(f: ca.Function, name: str, fixed: dict | None = None) -> ca.Function:
    """f under a new name, with dense outputs and common subexpressions merged (CasADi's
    ``cse``, 10-25 % fewer instructions); inputs named in `fixed` are bound to constants."""
    fixed = fixed or {}
    sym = ca.SX if f.is_a("SXFunction") else ca.MX
    ins = {f.name_in(i): sym.sym(f.name_in(i), f.sparsity_in(i)) for i in range(f.n_in())}
    outs = f.call({k: fixed.get(k, v) for k, v in ins.items()})
    free = [k for k in ins if k not in fixed]
    return ca.Function(name, [ins[k] for k in free], [ca.densify(outs[k]) for k in f.name_out()],
                       free, list(f.name_out()), {"cse": True})


@functools.cache
def kernels(problem: Problem, branch: int = 1) -> tuple[Kernel, ...]:
    """The generated kernels of a 4-RRR problem, in :data:`KERNELS` order (built once, cached);
    the exact preload (in exact_preload, preload and controller_step) on `branch` (+1, -1, 0)."""
    if not problem.closed_form:
        raise SceneError("mechanism.kind: 'graph' is not supported by codegen yet (the generated controller needs "
                         "the closed-form IK of an n-RRR scene: mechanism.kind n-rrr with 4 chains)")
    mech = problem.mechanism
    if mech.n != 4:
        raise SceneError(f"mechanism.chains: {mech.n} chains is not allowed for code generation "
                         "(the controller needs the 4-RRR's one degree of redundancy: 4 chains)")
    inv, exact = problem.inverse_dynamics(), exact_preload_function(problem, branch=branch)
    pose, pose_d, pose_dd = (ca.SX.sym(s, 3) for s in ("pose", "pose_d", "pose_dd"))
    preload = ca.Function("preload", [pose, pose_d, pose_dd], exact(*inv(pose, pose_d, pose_dd)),
                          ["pose", "pose_d", "pose_dd"], exact.name_out())
    jac = ca.Function("jacobian", [pose], mech.jacobian_function(pose)[::3], ["pose"], ["J", "sin_transmission"])
    sources = {
        "ik": (mech.ik_function, {"modes": ca.SX(ca.DM(mech.modes))}),
        "jacobian": (jac, None),
        "null_space": (mech.null_space_function, None),
        "trajectory": (trajectory_function(problem.path), None),
        "inverse_dynamics": (inv, None),
        "exact_preload": (exact, None),
        "preload": (preload, None),
        "controller_step": (controller_function(problem), None),
        "qp_preload": (qp_preload_function(problem, "qrqp"), None),
    }
    return tuple(Kernel(k, _renamed(sources[k][0], f"{RAW}_{k}", sources[k][1]), _KERNEL_DOC[k]) for k in KERNELS)


# ----------------------------------------------------------------------------- C text

def _c_param(f: ca.Function, i: int, output: bool) -> tuple[str, str, str]:
    """(declaration, name, comment line) of input/output i of f in the wrapper."""
    name = f.name_out(i) if output else f.name_in(i)
    sp = f.sparsity_out(i) if output else f.sparsity_in(i)
    r, c = sp.shape
    size = r * c
    if size == 1:
        decl = f"double *{name}" if output else f"double {name}"
    else:
        decl = f"{'' if output else 'const '}double {name}[{size}]"
    shape = "scalar" if size == 1 else (f"({r},)" if c == 1 else f"({r}x{c}), column-major: {name}[i + {r}*j]")
    line = f" *   {'out' if output else 'in '} {name} {shape}: {_IO_DOC[name]}"
    return decl, name, line


def _wrapper_doc_and_signature(k: Kernel) -> tuple[str, str]:
    f = k.function
    ins = [_c_param(f, i, False) for i in range(f.n_in())]
    outs = [_c_param(f, i, True) for i in range(f.n_out())]
    doc = "\n".join(["/* " + "\n * ".join(textwrap.wrap(k.doc, 100)), *[p[2] for p in ins + outs],
                     " * Output pointers may be NULL (that output is skipped). Returns 0 on success. */"])
    sig = f"int {WRAPPER}_{k.name}({', '.join(p[0] for p in ins + outs)})"
    return doc, sig


def _wrapper_body(k: Kernel) -> str:
    f, raw = k.function, f"{RAW}_{k.name}"
    lines = [f"  const casadi_real *arg[{raw}_SZ_ARG];", f"  casadi_real *res[{raw}_SZ_RES];",
             f"  casadi_int iw[{raw}_SZ_IW + 1];", f"  casadi_real w[{raw}_SZ_W + 1];"]
    for i in range(f.n_in()):
        scalar = f.sparsity_in(i).numel() == 1
        lines.append(f"  arg[{i}] = {'&' if scalar else ''}{f.name_in(i)};")
    lines += [f"  res[{i}] = {f.name_out(i)};" for i in range(f.n_out())]
    lines.append(f"  return {raw}(arg, res, iw, w, 0);")
    return "\n".join(lines)


def _header(problem: Problem, ks: tuple[Kernel, ...], branch: int) -> str:
    scene = problem.scene
    a = scene.actuation
    protos = "\n\n".join("{}\n{};".format(*_wrapper_doc_and_signature(k)) for k in ks)
    modes = ", ".join("+" if m > 0 else "-" for m in problem.mechanism.modes)
    return f"""/* rrr4.h: controller functions of the planar 4-RRR for scene '{scene.name}'.
 * Generated by rrr4 (rrr4.codegen); self-contained C99, no CasADi needed.
 *
 * Units are SI: m, rad, s, N, N m. Actuator i drives link i1 from base A_i; passive
 * joints are ordered B1..B4, C1..C4. Working modes (acos branch per chain): {modes}.
 * Matrices are stored column-major. Every function is re-entrant: its work arrays live
 * on the stack (at most a few kB) and nothing is allocated.
 * Low-level entry points in CasADi's calling convention are in {RAW}.h.
 */
#ifndef RRR4_H
#define RRR4_H

#ifdef __cplusplus
extern "C" {{
#endif

#define RRR4_N_ACTUATORS 4
#define RRR4_N_PASSIVE_JOINTS 8
#define RRR4_KP {a.kp!r} /* proportional gain [N m/rad] */
#define RRR4_KD {a.kd!r} /* derivative gain [N m s/rad] */
#define RRR4_MIN_FORCE {a.preload.min_force!r} /* required reaction at every passive joint [N] */
/* Branch of the exact preload: +1 alpha >= 0, -1 alpha <= 0, 0 global optimum per call
 * (which may jump between +-alpha and reverse every bearing force). */
#define RRR4_PRELOAD_BRANCH {branch}
/* The controller step's preload: method (none, exact or qp) and its fixed sign (+1 / -1:
 * the exact branch or the QP's axial-force sign); clearance compensation (none or
 * clearance); the rate it was designed to run at [Hz] (0: continuous in the simulation). */
#define RRR4_PRELOAD_METHOD "{a.preload.method if problem.has_preload else 'none'}"
#define RRR4_PRELOAD_SIGN {preload_sign(problem)}
#define RRR4_COMPENSATION "{a.compensation}"
#define RRR4_CONTROL_RATE {a.control_rate or 0.0!r}
#define RRR4_PATH_DURATION {scene.path.duration!r} /* duration of rrr4_trajectory's path [s] */

/* Torque limit of each actuator [N m]; torques are clipped to +-limit. */
extern const double rrr4_torque_limit[RRR4_N_ACTUATORS];

{protos}

#ifdef __cplusplus
}} /* extern "C" */
#endif

#endif /* RRR4_H */
"""


def _source(problem: Problem, ks: tuple[Kernel, ...]) -> str:
    scene = problem.scene
    lim = ", ".join(repr(float(v)) for v in scene.actuation.torque_limit)
    funcs = "\n\n".join(f"{_wrapper_doc_and_signature(k)[1]} {{\n{_wrapper_body(k)}\n}}" for k in ks)
    return f"""/* rrr4.c: wrappers of the CasADi-generated kernels ({RAW}.c) for scene '{scene.name}'. */
#include "{RAW}.h"
#include "{WRAPPER}.h"

const double rrr4_torque_limit[RRR4_N_ACTUATORS] = {{{lim}}};

{funcs}
"""


EXAMPLE_STEPS = 1000  # controller steps of the example (1 kHz)
EXAMPLE_PRINT_EVERY = 100
EXAMPLE_ANGLE_OFFSET = 1e-3  # [rad] the example's measured angle i lags the reference by (i + 1) times this


def _main_c(problem: Problem) -> str:
    scene = problem.scene
    return f"""/* Example: the rrr4 controller of scene '{scene.name}' run along its path at 1 kHz.
 *
 * Build and run (in this directory):   gcc -O2 -Wall *.c -lm -o example && ./example
 *
 * In a real controller, replace the 'measured' angles below by the encoder readings and
 * send tau to the drives. Lines: 'kinematics' and 'step' are machine-readable
 * (name, then %.17g numbers); lines starting with '#' are comments.
 */
#include <stdio.h>

#include "rrr4.h"

#define STEPS {EXAMPLE_STEPS}
#define PRINT_EVERY {EXAMPLE_PRINT_EVERY}
#define ANGLE_OFFSET {EXAMPLE_ANGLE_OFFSET!r} /* [rad] simulated tracking error of actuator i: (i + 1) * ANGLE_OFFSET */

static void print_row(const char *tag, double t, const double *v, int n, const double *extra, int n_extra) {{
  int i;
  printf("%s %.17g", tag, t);
  for (i = 0; i < n; ++i) printf(" %.17g", v[i]);
  for (i = 0; i < n_extra; ++i) printf(" %.17g", extra[i]);
  printf("\\n");
}}

int main(void) {{
  double pose[3], pose_d[3], pose_dd[3];
  double theta_ref[4], cos_arg[4], J[12], n[4];
  double theta[4], theta_d[4], tau[4], tau_ff[4], extra[2];
  int k, i, j;

  /* kinematics at the start of the path: theta (4), then J column-major (12), then n (4) */
  if (rrr4_trajectory(0.0, pose, pose_d, pose_dd) || rrr4_ik(pose, theta_ref, cos_arg) ||
      rrr4_jacobian(pose, J, NULL) || rrr4_null_space(pose, n)) return 1;
  for (i = 0; i < RRR4_N_ACTUATORS; ++i) {{
    if (cos_arg[i] < -1.0 || cos_arg[i] > 1.0) {{
      printf("# chain %d cannot reach the start pose\\n", i + 1);
      return 1;
    }}
  }}
  print_row("kinematics", 0.0, theta_ref, 4, J, 12);
  print_row("null_space", 0.0, n, 4, NULL, 0);

  printf("# t [s], tau [N m] (4), alpha [N m], feasible\\n");
  for (k = 0; k <= STEPS; ++k) {{
    double t = RRR4_PATH_DURATION * k / STEPS;
    rrr4_trajectory(t, pose, pose_d, pose_dd);
    /* stand-in for the encoders: reference angles with a fixed lag, rates J pose_d */
    rrr4_ik(pose, theta_ref, cos_arg);
    rrr4_jacobian(pose, J, NULL);
    for (i = 0; i < RRR4_N_ACTUATORS; ++i) {{
      theta[i] = theta_ref[i] - (i + 1) * ANGLE_OFFSET;
      theta_d[i] = 0.0;
      for (j = 0; j < 3; ++j) theta_d[i] += J[i + 4 * j] * pose_d[j];
    }}
    if (rrr4_controller_step(pose, pose_d, pose_dd, theta, theta_d, tau, tau_ff, NULL, NULL, &extra[0], &extra[1]))
      return 1;
    if (extra[1] == 0.0) printf("# t = %g s: preload infeasible, best effort\\n", t);
    if (k % PRINT_EVERY == 0) print_row("step", t, tau, 4, extra, 2);
  }}
  return 0;
}}
"""


_MAKEFILE = f"""# Builds the rrr4 example and a shared library of the controller functions.
CC ?= gcc
CFLAGS ?= -O2 -Wall
SOURCES = {RAW}.c {WRAPPER}.c

example: main.c $(SOURCES) {RAW}.h {WRAPPER}.h
\t$(CC) $(CFLAGS) main.c $(SOURCES) -lm -o $@

lib{WRAPPER}.so: $(SOURCES) {RAW}.h {WRAPPER}.h
\t$(CC) $(CFLAGS) -fPIC -shared $(SOURCES) -lm -o $@

run: example
\t./example

clean:
\trm -f example lib{WRAPPER}.so

.PHONY: run clean
"""


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


def preload_branch(problem: Problem, branch="auto") -> int:
    """The exact-preload branch of the exact_preload and preload kernels as +1 (alpha >= 0),
    -1 (alpha <= 0) or 0 (global optimum per instant). 'auto' is the controller's own sign
    (:func:`rrr4.preload.preload_sign`; +1 without a preload)."""
    if branch == "auto":
        return preload_sign(problem) or 1
    if branch in (0, 1, -1) and not isinstance(branch, bool):
        return int(branch)
    raise SceneError(f"branch: {branch!r} is not allowed (choose one of: auto, 1, -1, 0)")


def codegen(scene: Scene | Problem, out_dir, branch="auto") -> list[Path]:
    """Write the scene's controller C into out_dir (created if needed); return the files.

    Files: rrr4_raw.c, rrr4_raw.h (CasADi), rrr4.h, rrr4.c (wrappers), main.c, Makefile.
    The directory is written atomically (:func:`rrr4.files.atomic_directory`): out_dir must
    be new, empty or an earlier codegen output (holds rrr4.h), which is replaced whole, so an
    interrupted run leaves the earlier files intact. branch: the exact_preload and preload
    kernels' branch (:func:`preload_branch`); a fixed one keeps the torques continuous along a
    path. The controller step is the one :func:`rrr4.simulate` runs, with the scene's preload
    sign (:func:`rrr4.preload.preload_sign`).
    """
    problem = Problem.from_scene(scene)
    branch = preload_branch(problem, branch)
    ks = kernels(problem, branch)
    out = _out_dir(out_dir)
    cg = ca.CodeGenerator(f"{RAW}.c", {"with_header": True})
    for k in ks:
        cg.add(k.function)

    def fill(tmp: Path) -> None:
        cg.generate(str(tmp) + os.sep)
        for name, text in ((f"{WRAPPER}.h", _header(problem, ks, branch)), (f"{WRAPPER}.c", _source(problem, ks)),
                           ("main.c", _main_c(problem)), ("Makefile", _MAKEFILE)):
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


_GENERATED: dict[str, tuple[ca.Function, Path]] = {}


def generated_controller(problem: Problem) -> tuple[ca.Function, Path]:
    """The scene's controller step as :func:`codegen` writes it, compiled with the C compiler
    and loaded with ``casadi.external`` ('rrr4_raw_controller_step', same inputs and outputs
    as :func:`rrr4.control.controller_function`), and the path of its C source. Cached on disk
    (``rrr4.integrators.compiled.cache_dir()``) by the hash of the generated C."""
    import hashlib
    import tempfile

    from .integrators.compiled import cache_dir
    root = cache_dir()
    with tempfile.TemporaryDirectory(dir=root) as tmp:
        src = Path(tmp) / "src"
        codegen(problem, src)
        key = hashlib.sha256((src / f"{RAW}.c").read_bytes() + (src / f"{WRAPPER}.c").read_bytes()).hexdigest()[:24]
        if key in _GENERATED:
            return _GENERATED[key]
        final = root / f"controller_{key}"
        lib = final / f"lib{WRAPPER}.so"
        if not lib.exists():
            compile_library(src, src / lib.name)
            try:
                os.replace(src, final)  # atomic: never a half-built cache entry
            except OSError:  # another process put the same entry in place first: use theirs
                if not lib.exists():
                    raise
    _GENERATED[key] = (ca.external(f"{RAW}_controller_step", str(lib)), final / f"{RAW}.c")
    return _GENERATED[key]


def load_library(lib_path, names=KERNELS) -> dict[str, ca.Function]:
    """The compiled kernels as CasADi Functions (``casadi.external``), keyed by kernel name."""
    lib = str(Path(lib_path).resolve())
    return {k: ca.external(f"{RAW}_{k}", lib) for k in names}


"""The C text around the kernels: wrapper header and source, the example, the Makefile.

- ``rrr4.h`` (:func:`wrapper_header`): the scene's constants (gains, minimum force, preload
  method and sign, control rate, path duration) and one prototype ``rrr4_<kernel>(inputs...,
  outputs...)`` per kernel on double arrays, documented with the shape and unit of every
  argument (the parameter docs live here);
- ``rrr4.c`` (:func:`wrapper_source`): the wrappers, each calling CasADi's ``rrr4_raw_<kernel>``
  with its work arrays on the stack (no allocation, re-entrant);
- ``main.c`` (:func:`example_main`): an example controller loop along the scene's path at 1 kHz
  (a closed-form 4-RRR's, with its kinematics kernels; any other scene's, on its step alone);
- ``Makefile`` (:data:`MAKEFILE`): the example and a shared library.

Shapes come from the kernels' Functions themselves; units are SI (m, rad, s, N, N m).
"""

from __future__ import annotations

import textwrap

import casadi as ca

from ..control import reference_grid
from ..preload.signs import preload_sign
from ..problem import Problem
from .kernels import RAW, WRAPPER, Kernel, table_step

__all__ = ["texts", "wrapper_header", "wrapper_source", "example_main", "MAKEFILE", "EXAMPLE_STEPS",
           "EXAMPLE_PRINT_EVERY", "EXAMPLE_ANGLE_OFFSET"]

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
    "theta": "actuator angles [rad] (a prismatic actuator's displacement [m])",
    "theta_d": "actuator rates [rad/s] (a prismatic actuator's [m/s])",
    "cos_arg": "argument of acos per chain [-]; the pose is reachable iff all |cos_arg| <= 1",
    "J": "Jacobian, d theta = J d pose [rad/m, rad/m, rad/rad by column]",
    "sin_transmission": "sine of the angle between driving and following link [-] (0 = serial singularity)",
    "n": "unit null-space vector of J^T [-]: torques along n move nothing",
    "tau_p": "particular (minimum-norm) actuator torques [N m]",
    "tau_n": "null-space torque direction [-] (unit; tau = tau_p + alpha tau_n)",
    "r_p": "particular reactions at B1..B4, C1..C4, column j = [r_x, r_y] [N]",
    "r_n": "reactions per unit alpha at B1..B4, C1..C4 [N/(N m)]",
    "alpha": "preload along the null space [N m]",
    "tau": "actuator torques [N m] (a prismatic actuator's force [N])",
    "tau_ff": "feed-forward torques (inverse dynamics + preload (+ friction compensation)), before PD and "
              "clipping [N m]",
    "feasible": "[-] 1.0 if every passive joint carries >= min_force within the torque limits, else 0.0",
    "margin": "min_j |r_j| - min_force [N]",
}


def _c_param(f: ca.Function, i: int, output: bool) -> tuple[str, str, str]:
    """(declaration, name, comment line) of input/output i of f in the wrapper."""
    name = f.name_out(i) if output else f.name_in(i)
    sp = f.sparsity_out(i) if output else f.sparsity_in(i)
    r, c = sp.shape
    size = r * c
    if size == 1 or size == 0:  # a scalar, or an empty output (alpha without redundancy): a pointer
        decl = f"double *{name}" if output or size == 0 else f"double {name}"
    else:
        decl = f"{'' if output else 'const '}double {name}[{size}]"
    shape = ("scalar" if size == 1 else "empty (pass NULL)" if size == 0 else f"({r},)" if c == 1 else
             f"({r}x{c}), column-major: {name}[i + {r}*j]")
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


def _about(problem: Problem, ks: tuple[Kernel, ...]) -> tuple[str, str]:
    """(what the functions are, the header's notes on the mechanism) for rrr4.h."""
    if len(ks) > 2:  # the closed-form 4-RRR
        modes = ", ".join("+" if m > 0 else "-" for m in problem.mechanism.modes)
        notes = f""" * Units are SI: m, rad, s, N, N m. Actuator i drives link i1 from base A_i; passive
 * joints are ordered B1..B4, C1..C4. Working modes (acos branch per chain): {modes}."""
        return "controller functions of the planar 4-RRR", notes
    model = problem.model
    actuators = ", ".join(f"{a} ({problem.joint(j).type}, {model.effort_unit(j)})"
                          for a, j in zip(model.actuator_names, model.actuated_joints, strict=True))
    task = (f"the body {model.task!r}" if model.task_point is None else
            f"the point {tuple(model.task_point)} [m] of the body {model.task!r} (x, y of the pose)")
    how = ("references tabulated along the path" if table_step(ks) else "the closed-form step of an n-RRR")
    lines = textwrap.wrap(f"Units are SI: m, rad, s, N, N m. Actuators, in the order of every array: {actuators}. "
                          f"Task: {task}; poses [x, y, theta_o].", 88)
    return f"the controller step ({how})", "\n".join(f" * {line}" for line in lines)


def wrapper_header(problem: Problem, ks: tuple[Kernel, ...], branch: int) -> str:
    """rrr4.h: the scene's constants, the torque limits and one documented prototype per kernel;
    branch: the exact preload's (RRR4_PRELOAD_BRANCH, with the 4-RRR's exact_preload kernel)."""
    scene = problem.scene
    a = scene.actuation
    protos = "\n\n".join("{}\n{};".format(*_wrapper_doc_and_signature(k)) for k in ks)
    what, notes = _about(problem, ks)
    full = len(ks) > 2
    extra = (f"""#define RRR4_N_PASSIVE_JOINTS 8
/* Branch of the exact preload: +1 alpha >= 0, -1 alpha <= 0, 0 global optimum per call
 * (which may jump between +-alpha and reverse every bearing force). */
#define RRR4_PRELOAD_BRANCH {branch}
""" if full else f"#define RRR4_TABLE_SAMPLES {len(reference_grid(problem))} /* instants of the reference table */\n"
             if table_step(ks) else "")
    return f"""/* rrr4.h: {what} for scene '{scene.name}'.
 * Generated by rrr4 (rrr4.codegen); self-contained C99, no CasADi needed.
 *
{notes}
 * Matrices are stored column-major. Every function is re-entrant: its work arrays live
 * on the stack (at most a few kB) and nothing is allocated.
 * Low-level entry points in CasADi's calling convention are in {RAW}.h.
 */
#ifndef RRR4_H
#define RRR4_H

#ifdef __cplusplus
extern "C" {{
#endif

#define RRR4_N_ACTUATORS {problem.model.n_actuators}
#define RRR4_KP {a.kp!r} /* proportional gain [N m/rad] */
#define RRR4_KD {a.kd!r} /* derivative gain [N m s/rad] */
#define RRR4_MIN_FORCE {a.preload.min_force!r} /* required reaction at every passive joint [N] */
{extra}/* The controller step's preload: method (none, exact, qp or nlp) and its fixed sign (+1 / -1:
 * the exact branch or the QP's axial-force sign); clearance compensation (none or
 * clearance) and its seat model; the rate it was designed to run at [Hz] (0: continuous in the simulation). */
#define RRR4_PRELOAD_METHOD "{a.preload.method if problem.has_preload else 'none'}"
#define RRR4_PRELOAD_SIGN {preload_sign(problem)}
#define RRR4_COMPENSATION "{a.compensation if problem.compensates else 'none'}"
#define RRR4_SEAT_MODEL "{a.seat_model if problem.compensates else 'none'}" /* quasi_static or rolling */
#define RRR4_CONTROL_RATE {a.control_rate or 0.0!r}
#define RRR4_PATH_DURATION {scene.path.duration!r} /* duration of rrr4_trajectory's path [s] */

/* Torque limit of each actuator [N m] (a prismatic actuator's force limit [N]); efforts
 * are clipped to +-limit. */
extern const double rrr4_torque_limit[RRR4_N_ACTUATORS];

{protos}

#ifdef __cplusplus
}} /* extern "C" */
#endif

#endif /* RRR4_H */
"""


def wrapper_source(problem: Problem, ks: tuple[Kernel, ...]) -> str:
    """rrr4.c: the torque limits [N m] and the wrapper of every kernel."""
    scene = problem.scene
    lim = ", ".join(repr(float(v)) for v in scene.torque_limit)
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


def example_main(problem: Problem, ks: tuple[Kernel, ...]) -> str:
    """main.c: the controller run along the scene's path at 1 kHz, printing machine-readable rows."""
    if len(ks) == 2:
        return _step_example(problem, ks)
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


def _step_example(problem: Problem, ks: tuple[Kernel, ...]) -> str:
    """main.c of a scene other than the closed-form 4-RRR: its controller step alone."""
    scene, n = problem.scene, problem.model.n_actuators
    step = next(k for k in ks if k.name == "controller_step").function
    m = step.numel_out(4)
    where = "t" if table_step(ks) else "pose, pose_d, pose_dd"
    return f"""/* Example: the rrr4 controller of scene '{scene.name}' run along its path at 1 kHz.
 *
 * Build and run (in this directory):   gcc -O2 -Wall *.c -lm -o example && ./example
 *
 * In a real controller, replace the 'measured' coordinates below by the encoder readings
 * and send tau to the drives. Lines: 'step' rows are machine-readable (name, t, then tau
 * ({n}), alpha ({m}) and feasible as %.17g numbers); lines starting with '#' are comments.
 */
#include <stdio.h>

#include "rrr4.h"

#define STEPS {EXAMPLE_STEPS}
#define PRINT_EVERY {EXAMPLE_PRINT_EVERY}
/* simulated tracking error of actuator i: (i + 1) * ANGLE_OFFSET [rad or m] */
#define ANGLE_OFFSET {EXAMPLE_ANGLE_OFFSET!r}

int main(void) {{
  double pose[3], pose_d[3], pose_dd[3];
  double theta[{n}], theta_d[{n}], tau[{n}], theta_ref[{n}], theta_d_ref[{n}], extra[{m + 1}];
  int k, i;

  printf("# t [s], tau [{problem.effort_unit}] ({n}), alpha [{problem.effort_unit}] ({m}), feasible\\n");
  for (k = 0; k <= STEPS; ++k) {{
    double t = RRR4_PATH_DURATION * k / STEPS;
    if (rrr4_trajectory(t, pose, pose_d, pose_dd)) return 1;
    /* stand-in for the encoders: the step's own references with a fixed lag */
    for (i = 0; i < RRR4_N_ACTUATORS; ++i) theta[i] = theta_d[i] = 0.0;
    if (rrr4_controller_step({where}, theta, theta_d, NULL, NULL, theta_ref, theta_d_ref, NULL, NULL)) return 1;
    for (i = 0; i < RRR4_N_ACTUATORS; ++i) {{
      theta[i] = theta_ref[i] - (i + 1) * ANGLE_OFFSET;
      theta_d[i] = theta_d_ref[i];
    }}
    if (rrr4_controller_step({where}, theta, theta_d, tau, NULL, NULL, NULL, {"extra" if m else "NULL"},
                             &extra[{m}]))
      return 1;
    if (extra[{m}] == 0.0) printf("# t = %g s: preload infeasible, best effort\\n", t);
    if (k % PRINT_EVERY == 0) {{
      printf("step %.17g", t);
      for (i = 0; i < RRR4_N_ACTUATORS; ++i) printf(" %.17g", tau[i]);
      for (i = 0; i <= {m}; ++i) printf(" %.17g", extra[i]);
      printf("\\n");
    }}
  }}
  return 0;
}}
"""


MAKEFILE = f"""# Builds the rrr4 example and a shared library of the controller functions.
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


def texts(problem: Problem, ks: tuple[Kernel, ...], branch: int) -> dict[str, str]:
    """The hand-written files of a codegen output, by file name: rrr4.h, rrr4.c, main.c, Makefile."""
    return {f"{WRAPPER}.h": wrapper_header(problem, ks, branch), f"{WRAPPER}.c": wrapper_source(problem, ks),
            "main.c": example_main(problem, ks), "Makefile": MAKEFILE}

"""Helpers for CasADi Functions that every layer uses: evaluation on numpy arrays through the
buffer interface, mapped evaluation a block at a time, fixing a Function's last input
(``parameters`` or ``settings``) to numbers, the size of a Function's graph, Functions built to
be differentiated in many directions (:func:`one_direction_derivatives`), and the one home
of solver quiet: :data:`QUIET` options and :func:`solver_output_captured`."""

from __future__ import annotations

import contextlib
import io
import os
import sys
import tempfile
import threading
import weakref

import casadi as ca
import numpy as np

from .errors import SimulationError

__all__ = ["evaluate", "mapped", "mapped_function", "nonzeros", "fix_last_input", "graph_size", "QUIET",
           "solver_output_captured", "one_direction_derivatives"]

# Options of CasADi's oracle-based solvers (rootfinder, nlpsol, integrator): no warning line
# per failed evaluation. A Newton iteration that meets NaN otherwise prints one line per
# evaluation (about 30 000 for a floating sub-mechanism before its one error); the caller
# checks the result and reports a failure once.
QUIET = {"show_eval_warnings": False}


_DIRECTIONS_LOCK = threading.Lock()


@contextlib.contextmanager
def one_direction_derivatives():
    """The Functions built inside the block take forward derivatives one direction at a time
    (CasADi's ``max_num_dir`` 1, read when a Function is made): where a graph that calls them is
    differentiated in n directions (``Function.forward(n)``), each call becomes n calls of its
    one-direction derivative, one copy in the generated C, instead of one derivative with n
    directions unrolled, n copies. So a frame built of such Functions, its steps inlined, is
    evaluated once and differentiated in n directions by code that hardly grows with n (see
    :func:`rrr4.identify.dynamic.sensitivity_frame`). Functions built elsewhere while the block
    runs get it too: keep it around building, not around user code."""
    with _DIRECTIONS_LOCK:
        before = ca.GlobalOptions.getMaxNumDir()
        ca.GlobalOptions.setMaxNumDir(1)
        try:
            yield
        finally:
            ca.GlobalOptions.setMaxNumDir(before)


@contextlib.contextmanager
def solver_output_captured():
    """Capture what a solver prints inside the block, for the few outputs that no option turns
    off (qpOASES prints its copyright notice whenever a solver memory is made, whatever its
    printLevel). CasADi routes its C++ output through Python's sys.stdout and sys.stderr; a
    library that writes to the C streams goes to file descriptors 1 and 2: both are captured.
    Yields a list that holds the captured text once the block ends. The streams and the
    descriptors are the process's: use it only around a solver call, never around user code."""
    captured: list[str] = []
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    text = io.StringIO()
    with tempfile.TemporaryFile() as sink:
        saved = [os.dup(1), os.dup(2)]
        try:
            os.dup2(sink.fileno(), 1)
            os.dup2(sink.fileno(), 2)
            with contextlib.redirect_stdout(text), contextlib.redirect_stderr(text):
                yield captured
        finally:
            _flush_c_streams()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
            sink.seek(0)
            captured.append(text.getvalue() + sink.read().decode(errors="replace"))


def _flush_c_streams() -> None:
    """fflush(NULL): C's stdio buffers go to the descriptors they were written for."""
    with contextlib.suppress(Exception):
        import ctypes
        ctypes.CDLL(None).fflush(None)


def evaluate(f: ca.Function, args, results) -> None:
    """f on numpy arrays through CasADi's buffer interface: args and results (C-contiguous float
    arrays, each holding its input's or output's nonzeros in CasADi's column-major order; None:
    an input left at zero) are read and written in place. Converting to and from DM instead
    costs about 30 ns per number: with 11 frame inputs per control period, about a tenth of the
    reference scene's compiled stepping."""
    buf, run = f.buffer()
    for i, a in enumerate(args):
        if a is not None:
            buf.set_arg(i, memoryview(a.reshape(-1)))
    for i, r in enumerate(results):
        buf.set_res(i, memoryview(r.reshape(-1)))
    run()
    if buf.ret():
        raise SimulationError(f"evaluating {f.name()} failed")


def fix_last_input(f: ca.Function, values) -> ca.Function:
    """f with its last input (such as "parameters" or "settings") fixed to `values`:
    the same SX graph, the numbers folded in as constants."""
    ins = [ca.SX.sym(f.name_in(i), f.sparsity_in(i)) for i in range(f.n_in() - 1)]
    out = f.call([*ins, ca.DM(values)])
    return ca.Function(f.name(), ins, out, f.name_in()[:-1], f.name_out())


def graph_size(f: ca.Function) -> dict:
    """Size of a Function's graph: SX instructions, nodes and free-variable count."""
    return {"instructions": f.n_instructions(), "nodes": f.n_nodes(), "inputs": f.nnz_in()}


_MAPS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # Function handle -> {m: its map}
_MAPS_LOCK = threading.Lock()
MAPS_PER_FUNCTION = 16  # column counts kept per Function (a run's blocks take one or two)


def mapped_function(f: ca.Function, m: int) -> ca.Function:
    """f.map(m), built once (building one costs about 0.5 ms, as much as evaluating it on a
    few hundred columns) and kept exactly as long as the handle `f` lives: a weak-keyed cache,
    so a map never outlives, nor is found for another than, the Function it maps (a handle's
    identity is not reused while it lives), and dropping a problem's Functions drops their
    maps. At most :data:`MAPS_PER_FUNCTION` column counts per Function."""
    with _MAPS_LOCK:
        maps = _MAPS.setdefault(f, {})
        if m not in maps:
            if len(maps) >= MAPS_PER_FUNCTION:
                maps.clear()
            maps[m] = f.map(m)
        return maps[m]


def nonzeros(sp: ca.Sparsity) -> np.ndarray:
    """Where the nonzeros of the pattern `sp` lie in its dense column-major entries."""
    rows, cols = sp.get_triplet()
    return np.asarray(cols, int) * sp.size1() + np.asarray(rows, int)


def mapped(f: ca.Function, block: int = 4096, **inputs) -> dict:
    """f's outputs at each column of `inputs` (numpy arrays, one column per output instant),
    evaluated `block` columns at a time: the memory a long run's outputs take while they are
    converted out of CasADi stays bounded by the block, not by the run. Inputs and outputs go
    through CasADi's buffer interface, straight between numpy arrays and the evaluation
    (converting a DM to numpy costs about ten times the evaluation). An input not given is
    zero."""
    n = next(iter(inputs.values())).shape[1]
    ins = {f.index_in(k): (v, nonzeros(f.sparsity_in(f.index_in(k)))) for k, v in inputs.items()}
    outs = [(f.sparsity_out(i), nonzeros(f.sparsity_out(i))) for i in range(f.n_out())]
    # output i at instant j, column-major (rows, cols): the rows of a C-ordered (cols * n, rows) array
    out = [np.zeros((sp.size2() * n, sp.size1())) for sp, _ in outs]
    for a in range(0, n, block):
        m = min(block, n - a)
        args = [None] * f.n_in()
        for i, (v, nz) in ins.items():
            if nz.size:
                w = v.shape[1] // n  # columns per instant
                dense = np.asfortranarray(v[:, a * w:(a + m) * w], float).reshape(-1, order="F").reshape(m, -1)
                args[i] = np.ascontiguousarray(dense[:, nz])
        res = [np.empty((m, nz.size)) for _, nz in outs]
        evaluate(mapped_function(f, m), args, res)
        for o, v, (sp, nz) in zip(out, res, outs, strict=True):
            block_out = o[sp.size2() * a:sp.size2() * (a + m)].reshape(m, -1)  # a view: (m, rows * cols)
            block_out[:, nz] = v
    return {f.name_out(i): o.T for i, o in enumerate(out)}

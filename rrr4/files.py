"""Files rrr4 writes and the C compiler it runs: one place for each.

- :func:`atomic_file`: one file, written by any writer (a figure's, NumPy's) to a
  temporary name beside it and moved into place; :func:`write_atomic`: the same for text;
- :func:`atomic_directory`: a whole directory, filled in a temporary sibling that replaces
  the target only when complete (an interrupted or failed run leaves an earlier result as
  it was);
- :func:`run_c_compiler`: the system C compiler (``$CC``, else ``cc`` or ``gcc``), for the
  compiled stepping and for the generated controller alike;
- :func:`request_stop`: after it (the command line calls it on Ctrl-C or SIGTERM) nothing is
  moved into place any more, and the long loops (the simulation's stepping, a sweep's cases)
  raise KeyboardInterrupt at their next block (:func:`stop_requested`). The interrupt itself
  can be lost: a signal that lands inside a CasADi solver stops only that solver, which
  returns as if it had not converged, and the run would go on to write its results; the stop
  request is kept until the command ends.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from .errors import Rrr4Error, SceneError

__all__ = ["atomic_file", "write_atomic", "atomic_directory", "check_target", "check_writable", "run_c_compiler",
           "c_compiler", "BuildError", "request_stop", "stop_requested"]

_stop = [False]  # whether a stop was requested since the command started (see request_stop)


def request_stop(on: bool = True) -> None:
    """From now on, :func:`atomic_file` and :func:`atomic_directory` raise KeyboardInterrupt
    instead of moving anything into place, and :func:`stop_requested` is true;
    request_stop(False) clears the request."""
    _stop[0] = bool(on)


def stop_requested() -> bool:
    """Whether a stop was requested (see :func:`request_stop`)."""
    return _stop[0]


def _check_stop() -> None:
    if _stop[0]:
        raise KeyboardInterrupt


class BuildError(Rrr4Error, RuntimeError):
    """The C compiler failed or is missing; the message holds the command and its output."""


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_file(path, fill) -> Path:
    """Call fill(tmp) to write a file at a temporary name beside `path`, then move it into
    place (mode as for a new file under the umask). The temporary name ends in `path`'s
    suffix, for writers that choose the format by it. If fill raises (or is interrupted),
    the temporary file is removed and `path` is untouched: never a half-written file in
    place of an earlier one."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=f".tmp{path.suffix}")
    os.close(fd)
    try:
        fill(tmp)
        os.chmod(tmp, 0o666 & ~_umask())
        _check_stop()
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def write_atomic(path, text: str) -> Path:
    """Write `text` to `path` through a temporary file in the same directory (:func:`atomic_file`)."""
    return atomic_file(path, lambda tmp: Path(tmp).write_text(text))


def check_writable(out, key: str = "--out", kind: str = "directory") -> Path:
    """Refuse, before any work, an output `out` (a directory, or with kind='file' a file)
    that cannot be written: one that exists as the other kind, lies under a file, or whose
    nearest existing directory refuses a real write (probed with a temporary file, so that
    /proc, read-only mounts and permissions all count, for root too). Returns `out`."""
    out = Path(out)
    if kind == "directory" and out.exists() and not out.is_dir():
        raise SceneError(f"{key}: '{out}' is not allowed (it is a file; a directory is required)")
    if kind == "file" and out.is_dir():
        raise SceneError(f"{key}: '{out}' is not allowed (it is a directory; a file is required)")
    start = out.parent if kind == "file" else out
    parent = next((p for p in (start, *start.parents) if p.exists()), Path("."))
    if not parent.is_dir():
        raise SceneError(f"{key}: '{out}' is not allowed ('{parent}' is a file, not a directory)")
    if kind == "file" and parent != out.parent:
        raise SceneError(f"{key}: '{out}' is not allowed (the directory '{out.parent}' does not exist)")
    try:
        with tempfile.TemporaryFile(dir=parent):
            pass
    except OSError as e:
        raise SceneError(f"{key}: '{out}' is not allowed (cannot write into '{parent}': {e.strerror})") from None
    return out


def check_target(out: Path, marker: str) -> None:
    """`out` must be absent, an empty directory, or an earlier rrr4 output (it holds `marker`)."""
    if out.exists() and not out.is_dir():
        raise SceneError(f"out: '{out}' is a file (a directory is required)")
    if out.is_dir() and any(out.iterdir()) and not (out / marker).is_file():
        raise SceneError(f"out: '{out}' is not empty and holds no {marker} (give a new directory or an "
                         "earlier rrr4 output directory, which is then replaced)")


def atomic_directory(out, fill, marker: str) -> Path:
    """Call fill(tmp_dir) to write files, then put tmp_dir in place of `out`.

    `out` must pass :func:`check_target` (absent, empty, or an earlier output holding
    `marker`). If fill raises (or is interrupted), the temporary directory is removed and
    `out` is untouched.
    """
    out = Path(out)
    check_target(out, marker)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.tmp-", dir=out.parent))
    try:
        fill(tmp)
        os.chmod(tmp, 0o777 & ~_umask())
        _check_stop()
        if out.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
            os.replace(out, old / out.name)
            try:
                os.replace(tmp, out)
            except BaseException:
                os.replace(old / out.name, out)
                raise
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out


def c_compiler() -> str | None:
    """Path of the C compiler: $CC, else cc, else gcc (None if there is none)."""
    return os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")


def run_c_compiler(args: list[str], cwd, warnings_are_errors: bool = False) -> None:
    """Run the C compiler with `args` in `cwd`. Raises BuildError if it is missing, fails,
    or (with warnings_are_errors) prints anything."""
    cc = c_compiler()
    if cc is None:
        raise BuildError("cc: no C compiler found (set CC or install gcc)")
    p = subprocess.run([cc, *args], cwd=cwd, capture_output=True, text=True)
    if p.returncode != 0 or (warnings_are_errors and p.stderr.strip()):
        raise BuildError(f"{Path(cc).name} {' '.join(args)} failed in {cwd}:\n{p.stderr.strip()}")

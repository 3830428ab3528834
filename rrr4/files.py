"""Files rrr4 writes and the C compiler it runs: one place for each.

- :func:`atomic_file`: one file, written by any writer (a figure's, NumPy's) to a
  temporary name beside it and moved into place; :func:`write_atomic`: the same for text;
- :func:`atomic_directory`: a whole directory, filled in a temporary sibling that replaces
  the target only when complete (an interrupted or failed run leaves an earlier result as
  it was);
- :func:`run_c_compiler`: the system C compiler (``$CC``, else ``cc`` or ``gcc``), for the
  compiled stepping and for the generated controller alike;
- :func:`read_text`: the one bounded reader of a text file rrr4 reads (a scene, a spec, a
  table, measurements): it exists, is a regular file, not too large (checked before it is
  read), not binary, UTF-8 (a byte-order mark dropped); :func:`read_json`: the same for a JSON
  file, with its nesting bounded and, where asked, a mapping required;
- :func:`request_stop`: after it (the command line calls it on Ctrl-C or SIGTERM) nothing is
  moved into place any more, and the long loops (the simulation's stepping, a sweep's cases)
  raise KeyboardInterrupt at their next block (:func:`stop_requested`). The interrupt itself
  can be lost: a signal that lands inside a CasADi solver stops only that solver, which
  returns as if it had not converged, and the run would go on to write its results; the stop
  request is kept until the command ends.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from .errors import Rrr4Error, SceneError

__all__ = ["atomic_file", "write_atomic", "atomic_directory", "check_target", "check_writable", "run_c_compiler",
           "c_compiler", "BuildError", "request_stop", "stop_requested", "read_text", "read_json", "shown",
           "MAX_JSON_BYTES", "MAX_JSON_DEPTH"]

MAX_JSON_BYTES = 64 * 2**20  # largest JSON file read [bytes] (a summary.json is a few kB)
MAX_JSON_DEPTH = 64          # deepest nesting of objects and arrays

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


def shown(path) -> str:
    """A file name as shown in a one-line message: every unprintable character escaped."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(path))


def read_text(path, what: str, required: str, max_bytes: int, error=SceneError) -> str:
    """The text of the file `path` (`what` names it in errors, e.g. 'scene file'; `required`
    says what is allowed, e.g. 'a YAML scene file'): it must exist, be a regular file (not a
    directory, a device or a pipe), hold at most max_bytes (checked before reading), no NUL
    byte, and be UTF-8 (a leading byte-order mark is dropped). Raises `error` in one line."""
    p, name = Path(path), shown(path)
    if not p.exists():
        raise error(f"{what} '{name}' does not exist")
    if p.is_dir():
        raise error(f"{what} '{name}' is a directory ({required} is required)")
    if not p.is_file():
        raise error(f"{what} '{name}' is not a regular file (a device or a pipe; {required} is required)")
    try:
        size = p.stat().st_size
        if size > max_bytes:
            raise error(f"{what} '{name}' is too large ({size:,} bytes; at most {max_bytes:,})")
        with p.open("rb") as f:
            raw = f.read(max_bytes + 1)
    except OSError as e:
        raise error(f"{what} '{name}' cannot be read ({e.strerror})") from None
    if len(raw) > max_bytes:  # it grew while read
        raise error(f"{what} '{name}' is too large (more than {max_bytes:,} bytes)")
    if b"\0" in raw:
        raise error(f"{what} '{name}' is binary ({required} is required)")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise error(f"{what} '{name}' is not UTF-8 text (invalid byte at offset {e.start}; {required} is "
                    "required)") from None


def read_json(path, what: str = "JSON file", mapping: bool = True, max_bytes: int = MAX_JSON_BYTES,
              max_depth: int = MAX_JSON_DEPTH, error=Rrr4Error):
    """The data of the JSON file `path` (`what` names it in errors), read by :func:`read_text`:
    valid JSON, nested at most max_depth deep, and with `mapping` an object (a list or a number
    is refused by its type, never echoed). Raises `error` in one line."""
    name = shown(path)
    text = read_text(path, what, "a JSON text file", max_bytes, error)
    deep = f"{what} '{name}' is nested too deeply (at most {max_depth} levels of objects and arrays)"
    try:
        data = json.loads(text)
    except json.JSONDecodeError as e:
        raise error(f"{what} '{name}' is not valid JSON (line {e.lineno}, column {e.colno}: {e.msg})") from None
    except RecursionError:
        raise error(deep) from None
    stack = [(data, 1)]
    while stack:
        v, depth = stack.pop()
        if isinstance(v, (dict, list)):
            if depth > max_depth:
                raise error(deep)
            stack.extend((x, depth + 1) for x in (v.values() if isinstance(v, dict) else v))
    if mapping and not isinstance(data, dict):
        raise error(f"{what} '{name}' is not a JSON object (it holds a {type(data).__name__}; an object of keys is "
                    "required)")
    return data


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

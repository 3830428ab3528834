"""Compiled C, cached on disk: the one place rrr4 turns C text into a loaded shared library.

:func:`library` compiles C sources with the system C compiler into a shared library in the
cache directory (:func:`cache_dir`: ``$RRR4_CACHE`` if set, else ``~/.cache/rrr4``) and
:func:`load` loads a symbol of it with ``casadi.external``. Both the compiled stepping
(:func:`rrr4.integrators.compiled.compiled`) and the generated controller in the loop
(:func:`rrr4.codegen.generated_controller`) are built here.

- The library ``<stem>_<key>.so`` is named after the SHA-256 of the C sources, the compiler
  flags and the CPU, so a second run of the same scene and method finds it and does not
  recompile.
- A lock file per library (``fcntl``) makes processes that need the same one at once (sweep
  workers) compile it once: the second waits for the first one's library.
- The library is compiled in a temporary directory and moved into place atomically: never a
  half-written cache entry. Sources kept on request (a C file that a later library compiles
  in, or that a user reads) are moved into ``<stem>_<key>/`` before the library appears.

The code is compiled for the CPU it runs on (:data:`COMPILE_FLAGS`: ``-O3 -march=native``),
with floating-point contraction off and ``errno`` ignored by the math functions, so that it
computes bit for bit what ``-O2`` code computes, only faster; ``-fno-semantic-interposition``
lets the compiler inline CasADi's small helpers (``casadi_sq``, ``casadi_fmax``,
``casadi_norm_inf``, ...), which a shared library otherwise calls through its procedure
linkage table. Together 1.5x on the reference scene's stepping (``benchmarks/bench_flags.py``).
Because the library is specific to the CPU, the CPU (:func:`cpu`) is part of its key: a cache
shared by different machines keeps one library per CPU. A compiler that refuses these flags
compiles with :data:`PORTABLE_FLAGS` instead. :func:`machine` names the same CPU for people
(the machine line of benchmark reports).
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

import casadi as ca

from ..files import BuildError, c_compiler, run_c_compiler
from .host import cache_dir, cpu, machine
from .policy import level as level_for
from .policy import remember_compile

__all__ = ["library", "library_path", "source_bytes", "flags_for", "library_in_background", "pending",
           "compile_staged", "spawn", "load", "cache_dir", "compilations", "compile_time", "compile_notice",
           "decision_notice", "say", "cpu", "machine", "COMPILE_FLAGS", "PORTABLE_FLAGS", "BuildError"]

PORTABLE_FLAGS = ("-O2", "-fPIC", "-shared")
COMPILE_FLAGS = ("-O3", "-march=native", "-ffp-contract=off", "-fno-math-errno", "-fno-semantic-interposition",
                 "-fPIC", "-shared")
NICE = 5  # niceness of a background compiler: the run it serves, and everyone else's, go first
NICE_LATER = 19  # of one whose library serves later runs only: it takes what nobody else wants
LATER_AFTER = 120.0  # [s] and it starts when the process that asked for it ends, or this long after
AFTER = ".after"  # the file of a staged directory naming the process a deferred compiler waits for
ALIVE = ".alive"  # the file of a staged directory its background compiler holds locked while it lives
_loaded: dict[tuple[str, str], ca.Function] = {}
_compilations = [0]  # libraries this process built (not found in the cache)
_compile_time = [0.0]  # [s] this process spent compiling them (and waiting for another's compiler)
_notice: list = [None]  # called with the library's stem before the compiler runs
_said: list = [None]  # called with a compile policy's decision that runs no compiler


def compilations() -> int:
    """How many libraries this process has compiled (cache hits excluded)."""
    return _compilations[0]


def compile_time() -> float:
    """Seconds this process has spent compiling libraries, or waiting for another process
    compiling one it needs (cache hits cost nothing here); callers take differences."""
    return _compile_time[0]


def compile_notice(notice=None):
    """Set the callable notice(stem) that :func:`library` calls just before it runs the C
    compiler (e.g. the command line's 'compiling ...' line); None for silence. Returns the
    previous one, to restore."""
    previous, _notice[0] = _notice[0], notice
    return previous


def decision_notice(say=None):
    """Set the callable say(text) that :func:`say` calls with a compile policy's decision that
    runs no compiler (e.g. the command line's line); None for silence. Returns the previous one."""
    previous, _said[0] = _said[0], say
    return previous


def say(text: str) -> None:
    """Tell the user, through :func:`decision_notice`'s callable, what the compile policy decided."""
    if _said[0] is not None:
        _said[0](text)


def library(stem: str, sources: Mapping[str, str], extra: Sequence = (), keep_sources: bool = False,
            level: str | None = None) -> Path:
    """The shared library ``<stem>_<key>.so`` in :func:`cache_dir` built from `sources`; its path.

    sources: file name -> C text, written side by side; the ``.c`` files are compiled, the
    others (headers) only included. extra: further C files (paths) compiled into the same
    library, e.g. the generated code of an external Function that the sources call. The key
    hashes the texts of both, the flags and the CPU. keep_sources: keep `sources` in the
    directory ``<stem>_<key>/`` next to the library (its path without the suffix). level: the
    -O level (default the one :func:`rrr4.codegen.policy.level` gives the sources' size).

    A library that a background compiler (:func:`library_in_background`) is making now is
    waited for, not compiled a second time. Compiled with :data:`COMPILE_FLAGS`, or
    :data:`PORTABLE_FLAGS` where the compiler refuses them. Raises BuildError (an Rrr4Error)
    if no C compiler ($CC, cc or gcc) is available or compilation fails.
    """
    extra = [Path(p).resolve() for p in extra]
    flags = flags_for(sources, level)
    lib = library_path(stem, sources, extra, level)
    if lib.exists():
        return lib
    start = time.perf_counter()
    try:
        if pending(lib):
            if _notice[0] is not None:
                _notice[0](f"{stem} (started in the background; waiting for it)")
            while pending(lib) and not lib.exists():
                time.sleep(0.05)
            if lib.exists():
                return lib
        if _notice[0] is not None:
            _notice[0](stem)
        return _compile(lib, sources, extra, flags, keep_sources)
    finally:
        _compile_time[0] += time.perf_counter() - start


def source_bytes(sources: Mapping[str, str]) -> int:
    """Bytes of the C files (not the headers) among `sources`."""
    return sum(len(text) for name, text in sources.items() if name.endswith(".c"))


def flags_for(sources: Mapping[str, str], level: str | None = None) -> tuple:
    """:data:`COMPILE_FLAGS` (read at call time: benchmarks swap it) with the -O level that
    :func:`rrr4.codegen.policy.level` gives the size of `sources` (-O0 beyond it, when forced),
    or `level` if given."""
    lv = level or level_for(source_bytes(sources)) or "-O0"
    return tuple(lv if f == "-O3" else f for f in COMPILE_FLAGS)


def library_path(stem: str, sources: Mapping[str, str], extra: Sequence = (), level: str | None = None) -> Path:
    """Where :func:`library` keeps the library of these sources (it may not exist yet)."""
    flags = flags_for(sources, level)
    key = hashlib.sha256("\n".join([*sources.values(), " ".join(flags), cpu(),
                                    *(Path(p).read_text() for p in extra)]).encode()).hexdigest()[:24]
    return cache_dir() / f"{stem}_{key}.so"


def library_in_background(stem: str, sources: Mapping[str, str], extra: Sequence = (), keep_sources: bool = False,
                          urgent: bool = False, about: str = "", level: str | None = None, later: bool = False) -> Path:
    """The path of :func:`library`'s library for these sources, compiled by a process of its own
    if it is not in the cache yet: the caller goes on at once and finds the library there
    (``path.exists()``) once it is done, later in its run or in a later run; :func:`library`
    asked for it meanwhile waits for that process instead of compiling it again. The process
    outlives the caller (an interrupted run still leaves the library for the next one). It
    runs at a lower priority (:data:`NICE`; :data:`NICE_LATER`, the least, if `later`: a
    library that serves later runs only, whose compiler should not slow this one, and which
    starts when this process ends or :data:`LATER_AFTER` seconds on, whichever comes first;
    this process compiles it itself if it asks :func:`library` for it meanwhile) and one such
    compiler at a time per cache directory (the others wait their turn), unless `urgent` (a
    library the caller will wait for soon, e.g. a generated controller: at once, at the normal
    priority). A library
    another process is compiling already is left to it. keep_sources, level: as in :func:`library`;
    about: what the caller's policy decided, for the notice. Raises BuildError without a C
    compiler."""
    if c_compiler() is None:
        raise BuildError("cc: no C compiler found (set CC or install gcc)")
    extra = [str(Path(p).resolve()) for p in extra]
    lib = library_path(stem, sources, extra, level)
    if lib.exists() or pending(lib):
        return lib
    with open(lib.with_suffix(".lock"), "a") as lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:  # another process compiles it now
            return lib
        if _notice[0] is not None:
            _notice[0](f"{stem} in the background ({about + '; ' if about else ''}CasADi's virtual machine steps "
                       "until it is ready)" if not urgent else f"{stem} in the background")
        staged = Path(tempfile.mkdtemp(prefix=f"{lib.stem}.", suffix=".staged", dir=lib.parent))
        alive = open(staged / ALIVE, "w")  # locked as long as the compiler lives (see pending)
        fcntl.flock(alive, fcntl.LOCK_EX)
        if later:  # it waits for this process (see compile_staged), which must not wait for it
            (staged / AFTER).write_text(str(os.getpid()))
        for name, text in sources.items():
            (staged / name).write_text(text)
        fcntl.flock(lock, fcntl.LOCK_UN)
    with alive:  # the compiler inherits the locked descriptor; ours closes, its lock stays
        spawn([str(lib), str(staged), ",".join(o for o, on in (("keep", keep_sources), ("urgent", urgent),
                                                                (f"later{os.getpid()}", later),
                                                                (level, level is not None))
                        if on),
               *extra], alive.fileno())
    return lib


def pending(lib: Path) -> bool:
    """Whether a background compiler (:func:`library_in_background`) is compiling, or waits
    its turn to compile, the library `lib`: a staged directory of it whose :data:`ALIVE` file
    a living process holds locked (a compiler killed outright leaves one nobody holds)."""
    for staged in lib.parent.glob(f"{lib.stem}.*.staged"):
        with contextlib.suppress(OSError, ValueError):
            if int((staged / AFTER).read_text()) == os.getpid():
                continue  # deferred until this process ends: not to be waited for here
        try:
            with open(staged / ALIVE) as alive:
                try:
                    fcntl.flock(alive, fcntl.LOCK_SH | fcntl.LOCK_NB)
                except BlockingIOError:
                    return True
        except FileNotFoundError:  # being staged or being removed
            with contextlib.suppress(FileNotFoundError):
                if time.time() - staged.stat().st_mtime < 10.0:
                    return True
    return False


def spawn(args: list[str], alive: int) -> None:
    """Start :func:`compile_staged` (args: the library, the staged sources, its options, extra
    C files) in a detached process of its own, which outlives this one and inherits the
    locked descriptor `alive` (see :func:`pending`)."""
    subprocess.Popen([sys.executable, "-c", "import sys; from rrr4.codegen.build import compile_staged; "
                      "compile_staged(*sys.argv[1:])", *args], stdin=subprocess.DEVNULL,
                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True, pass_fds=(alive,))


def compile_staged(lib: str, staged: str, options: str = "", *extra: str) -> None:
    """The background compiler of :func:`library_in_background`: the sources staged in the
    directory `staged` into `lib`; options: 'keep' (keep the sources beside the library),
    'urgent' (at once, at the normal priority; otherwise at :data:`NICE`, or with 'later<pid>'
    at :data:`NICE_LATER` once the process pid has ended (at most :data:`LATER_AFTER` s on),
    and one such compiler
    at a time per cache directory), an -O level (e.g. '-O1'; default by size). The staged directory
    is removed whatever happens."""
    lib_path, src, opts = Path(lib), Path(staged), options.split(",")
    try:
        with open(lib_path.parent / "background.lock", "a") as turn:
            after = next((int(o[5:]) for o in opts if o.startswith("later")), None)
            if "urgent" not in opts:
                with contextlib.suppress(OSError):
                    os.nice(NICE_LATER if after else NICE)
            if after:  # for later runs: not while the run that asked for it goes on
                _wait_for_end(after, LATER_AFTER)
                fcntl.flock(turn, fcntl.LOCK_EX)  # one background compiler at a time
            sources = {p.name: p.read_text() for p in sorted(src.iterdir())
                       if p.is_file() and not p.name.startswith(".")}  # not ALIVE, AFTER
            lv = next((o for o in opts if o.startswith("-O")), None)
            _compile(lib_path, sources, [Path(p) for p in extra], flags_for(sources, lv), "keep" in opts)
    finally:
        shutil.rmtree(src, ignore_errors=True)


def _compile(lib: Path, sources: Mapping[str, str], extra: list, flags: tuple, keep_sources: bool) -> Path:
    """Compile `lib` (see :func:`library`), or wait for the process compiling it."""
    # one compiler per library: a process (e.g. another sweep worker) that needs the same
    # library waits for it instead of compiling it again
    with open(lib.with_suffix(".lock"), "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if lib.exists():
            return lib
        with tempfile.TemporaryDirectory(dir=lib.parent) as tmp:
            src = Path(tmp) / "src"
            src.mkdir()
            for name, text in sources.items():
                (src / name).write_text(text)
            tmp_lib = Path(tmp) / lib.name
            files = [*(str(src / n) for n in sources if n.endswith(".c")), *map(str, extra), "-o", str(tmp_lib),
                     "-lm"]
            cpu_before = _children_cpu()
            try:
                run_c_compiler([*flags, *files], src)
                remember_compile(source_bytes(sources) + sum(Path(p).stat().st_size for p in extra),
                                 next((f for f in flags if f.startswith("-O")), ""), _children_cpu() - cpu_before)
            except BuildError:  # e.g. a compiler without -march=native: the same code, portable
                run_c_compiler([*PORTABLE_FLAGS, *files], src)
            if keep_sources:  # in place before the library, which marks a complete entry
                kept = lib.with_suffix("")
                if kept.exists():  # left by an interrupted run (we hold the lock)
                    shutil.rmtree(kept)
                os.replace(src, kept)
            os.replace(tmp_lib, lib)  # atomic: never a half-written cache entry
        _compilations[0] += 1
    return lib


def _wait_for_end(pid: int, at_most: float) -> None:
    """Return once the process `pid` has ended, or after `at_most` seconds."""
    end = time.monotonic() + at_most
    while time.monotonic() < end:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return
        except PermissionError:
            pass
        time.sleep(0.2)


def _children_cpu() -> float:
    """CPU seconds [user + system] of this process's finished children (the compiler's time on
    one core, hardly changed by the machine's load)."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def load(name: str, lib) -> ca.Function:
    """The Function `name` of the shared library `lib` (``casadi.external``), loaded once per process."""
    key = (name, str(lib))
    if key not in _loaded:
        _loaded[key] = ca.external(name, str(lib))
    return _loaded[key]

"""Where and for what the C is compiled: the compile cache's directory (:func:`cache_dir`) and
the CPU (:func:`cpu`, part of every library's key and the section of this machine's measured
costs; :func:`machine` for people). Used by :mod:`.build` and :mod:`.policy`."""

from __future__ import annotations

import functools
import os
import platform
from pathlib import Path

__all__ = ["cache_dir", "cpu", "machine"]


def cache_dir() -> Path:
    """Directory of the compiled libraries (created if needed)."""
    d = Path(os.environ.get("RRR4_CACHE") or Path.home() / ".cache" / "rrr4")
    d.mkdir(parents=True, exist_ok=True)
    return d


@functools.cache
def _cpuinfo() -> str:
    """/proc/cpuinfo, read once ('' where there is none)."""
    try:
        return Path("/proc/cpuinfo").read_text()
    except OSError:
        return ""


@functools.cache
def cpu() -> str:
    """What identifies this machine's CPU for -march=native (part of every library's key): the
    model and feature flags of its first processor (Linux), else what the platform module knows."""
    first = _cpuinfo().split("\n\n")[0]
    keep = [line for line in first.splitlines() if line.split(":")[0].strip() in ("vendor_id", "model name",
                                                                                "flags", "Features", "CPU part")]
    if keep:
        return "\n".join(keep)
    return f"{platform.machine()} {platform.processor()}"


def machine() -> str:
    """'AMD EPYC 7B13 (x86_64 Linux), 2 cores': the CPU where times are measured."""
    name = platform.processor() or platform.machine()
    for line in _cpuinfo().splitlines():
        if line.startswith("model name"):
            name = line.split(":", 1)[1].strip()
            break
    return f"{name} ({platform.machine()} {platform.system()}), {os.cpu_count()} cores"

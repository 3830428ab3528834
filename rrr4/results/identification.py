"""What an identification leaves behind (``rrr4 identify``): identified.yaml (the scene with
the estimates), identification.json (estimates, intervals, correlation, fit, verdict) and
its figures, written atomically into one directory."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import yaml

from ..files import atomic_directory
from .figures.identification import plot_correlation, plot_identification_fit, plot_identification_residuals

__all__ = ["write_identification", "MARKER"]

MARKER = "identification.json"


def _plain(v):
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not np.isfinite(v):
        return None
    return v


def write_identification(ident, out) -> list[str]:
    """Write identified.yaml (when the nominal scene has its YAML), identification.json,
    fit.png, residuals.png and correlation.png into `out` (replaced atomically; an earlier
    directory must hold identification.json). Returns the file names."""
    files: list[str] = []

    def fill(tmp: Path) -> None:
        if ident.identified_yaml is not None:
            head = (f"# {ident.scene.name} with the parameters identified by rrr4 identify (method "
                    f"{ident.method}): {', '.join(ident.keys)}\n"
                    + "".join(f"# stage {k + 1}, {st['said']}\n" for k, st in enumerate(ident.fit.get("stages", []))))
            (tmp / "identified.yaml").write_text(head + yaml.safe_dump(_plain(ident.identified_yaml),
                                                                       sort_keys=False))
            files.append("identified.yaml")
        (tmp / MARKER).write_text(json.dumps(_plain(ident.summary()), indent=1) + "\n")
        files.append(MARKER)
        for name, plot in (("fit.png", plot_identification_fit), ("residuals.png", plot_identification_residuals),
                           ("correlation.png", plot_correlation)):
            plot(ident, tmp / name)
            files.append(name)

    atomic_directory(Path(out), fill, MARKER)
    return files

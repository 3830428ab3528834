"""What every figure shares: matplotlib on the Agg backend, the arms' colours and labels
(:data:`STYLE`), and the one way a figure reaches its file (:func:`save_figure`)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.animation import Animation  # noqa: E402

from ...files import atomic_file  # noqa: E402

__all__ = ["STYLE", "save_figure"]

# arm -> colour and label, the same in every figure: with preload blue, compensated green,
# without preload orange; a driven scene's clearance run red and its ideal twin black
STYLE = {"with_preload": {"color": "tab:blue", "label": "with preload"},
         "with_preload_compensated": {"color": "tab:green", "label": "with preload, compensated"},
         "without_preload": {"color": "tab:orange", "label": "without preload"},
         "with_clearance": {"color": "tab:red", "label": "with clearance"},
         "ideal": {"color": "k", "label": "ideal joints"}}


def save_figure(fig, path, **options) -> Path:
    """Write `fig` to `path` atomically (:func:`rrr4.files.atomic_file`): an interrupted or
    failed write leaves an earlier file as it was. `fig` is a matplotlib Figure (written with
    ``savefig(**options)``, e.g. dpi, then closed) or an Animation (``save(**options)``, e.g.
    writer; its figure is the caller's to close). The format follows `path`'s suffix."""
    if isinstance(fig, Animation):
        return atomic_file(path, lambda tmp: fig.save(tmp, **options))
    try:
        return atomic_file(path, lambda tmp: fig.savefig(tmp, **options))
    finally:
        plt.close(fig)

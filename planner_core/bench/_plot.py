"""Figure helpers shared by the report's sections (matplotlib's Agg canvas, no pyplot state)."""

from __future__ import annotations

import io
import os
from pathlib import Path
from typing import Any

from planner_core.bench._io import write_bytes_atomic

__all__ = ["new_figure", "rel", "save"]


def new_figure(figsize: tuple[float, float]) -> Any:
    """A matplotlib Figure (inches) on its own Agg canvas, constrained layout."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save(fig: Any, path: Path) -> Path:
    """Write the figure as PNG (110 dpi) atomically; return the path."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return write_bytes_atomic(path, buf.getvalue())


def rel(path: Path, start: Path) -> str:
    """`path` relative to folder `start`, with forward slashes (for markdown links)."""
    return Path(os.path.relpath(path.resolve(), start.resolve())).as_posix()

"""Small helpers shared by command modules."""

from __future__ import annotations

import os
import stat
import sys
from pathlib import Path
from typing import Any

from lamde_mission.errors import UsageError


def load_map_or_fail(path: str) -> Any:
    """Load and validate a map; turn every problem into a UsageError naming the field."""
    from planner_core.mapio import MapError, load_map

    try:
        m = load_map(path)
    except MapError as exc:
        lines = (p if p.startswith(f"{path}: ") else f"{path}: {p}" for p in exc.problems)
        raise UsageError("\n".join(lines)) from None
    for note in m.notes:
        print(f"note: {path}: {note}", file=sys.stderr)
    return m


def check_output_path(path: str | None, flag: str) -> None:
    """Refuse, before any work is done, an output path that is a directory, a named pipe or a
    device, or whose folder is not a directory; UsageError naming the option."""
    if not path:
        return
    from planner_core.textio import not_regular

    p = Path(path)
    try:
        st = os.stat(p)
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise UsageError(f"{flag}: {path}: cannot be written ({exc.strerror or exc})") from None
    if st is not None and not stat.S_ISREG(st.st_mode):
        raise UsageError(f"{flag}: {path} {not_regular(st.st_mode)}")
    folder = p.parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir():
        raise UsageError(f"{flag}: {path}: {folder} is not a folder")

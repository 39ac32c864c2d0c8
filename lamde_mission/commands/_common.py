"""Small helpers shared by command modules."""

from __future__ import annotations

import sys
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

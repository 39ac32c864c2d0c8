"""Shared fixtures: small hand-readable maps built in code."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
MAPS = ROOT / "examples" / "maps"
SUITE = MAPS / "suite"

HAND_MAP = {
    "name": "hand",
    "area": {"width": 1000, "height": 1000},
    "start": [0, 0],
    "end": [300, 400],
    "sensors": [
        {"id": "a", "x": 300, "y": 0},
        {"id": "b", "x": 300, "y": 300, "required_data": 400},
    ],
    "uav": {"max_hover_points": 2},
    "radio": {"bandwidth": 15},
}


@pytest.fixture
def hand_map() -> dict:
    """Hover at (300, 0) for 50 s between start (0, 0) and end (300, 400): every term by hand."""
    return copy.deepcopy(HAND_MAP)

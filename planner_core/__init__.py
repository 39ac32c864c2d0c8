"""LAMDE's planning core: the map, the paper's model as a vectorised evaluator, the optimiser.

The names below are loaded on first use (PEP 562), so importing a light submodule such as
`planner_core.defaults` (the CLI does, to build `--help`) does not load numpy, shapely or numba.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "Map",
    "MapError",
    "ModelParams",
    "PENALTY_FACTOR",
    "Problem",
    "flight_time",
    "load_map",
    "map_json_schema",
    "penalised_score",
]

_WHERE = {
    "Map": "planner_core.model.mapio",
    "MapError": "planner_core.model.mapio",
    "load_map": "planner_core.model.mapio",
    "map_json_schema": "planner_core.model.mapio",
    "ModelParams": "planner_core.model.formulas",
    "PENALTY_FACTOR": "planner_core.model.formulas",
    "Problem": "planner_core.model.problem",
    "flight_time": "planner_core.model.formulas",
    "penalised_score": "planner_core.model.formulas",
}


def __getattr__(name: str) -> Any:
    try:
        module = _WHERE[name]
    except KeyError:
        raise AttributeError(f"module 'planner_core' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))

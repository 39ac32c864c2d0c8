"""LAMDE's planning core: the map, the paper's model as a vectorised evaluator, the optimiser."""

from planner_core.mapio import Map, MapError, load_map, map_json_schema
from planner_core.problem import PENALTY_FACTOR, Problem, flight_time, penalised_score

__all__ = [
    "Map",
    "MapError",
    "PENALTY_FACTOR",
    "Problem",
    "flight_time",
    "load_map",
    "map_json_schema",
    "penalised_score",
]

"""LAMDE's planning core: the map, the paper's model as a vectorised evaluator, the optimiser."""

from planner_core.mapio import Map, MapError, load_map, map_json_schema
from planner_core.model import PENALTY_FACTOR, ModelParams, flight_time, penalised_score
from planner_core.problem import Problem

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

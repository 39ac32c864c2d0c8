"""Routing on a map with obstacles, shared by the seeder and the map generator.

`offset`: convex polygons pushed out by a margin (mitre offset; circles as circumscribed
polygons). `graph`: the reduced visibility graph over pushed-out corners with a compiled
Dijkstra, and all-pairs shortest paths with next hops. `tour`: an open tour with fixed ends
(nearest neighbour, then 2-opt).
"""

from planner_core.model.routing.graph import (
    VisibilityGraph,
    build_visibility_graph,
    path_hops,
    shortest_paths,
)
from planner_core.model.routing.offset import CIRCLE_SIDES, obstacle_polygons, offset_convex
from planner_core.model.routing.tour import open_path, open_tour, path_cost

__all__ = [
    "CIRCLE_SIDES",
    "VisibilityGraph",
    "build_visibility_graph",
    "obstacle_polygons",
    "offset_convex",
    "open_path",
    "open_tour",
    "path_cost",
    "path_hops",
    "shortest_paths",
]

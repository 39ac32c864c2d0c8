"""Sorties and fleets (issue 33): plans a battery can fly, swaps at depots, several UAVs.

`model` (a `Sortie`, a `FleetPlan`, their scores with the energy module's formula), `lp` (the
hover-time LP across sorties), `split` (the optimal split of a tour into battery-sized
sorties with depot choice), `search` (`plan_fleet`: the sortie planner; `route_first`: the
route-first cluster-second peer). `lamde_mission.plan` returns a fleet plan for a map with a
battery or a fleet; docs/sorties.md describes the method and its measured results.
"""

from planner_core.fleet.lp import collected_by_sortie, fleet_hover_lp
from planner_core.fleet.model import FleetPlan, FleetSettings, Sortie
from planner_core.fleet.search import FleetResult, plan_fleet, route_first, sortie_map_dict
from planner_core.fleet.split import Links, split_tour, split_vehicles

__all__ = [
    "FleetPlan",
    "FleetResult",
    "FleetSettings",
    "Links",
    "Sortie",
    "collected_by_sortie",
    "fleet_hover_lp",
    "plan_fleet",
    "route_first",
    "sortie_map_dict",
    "split_tour",
    "split_vehicles",
]

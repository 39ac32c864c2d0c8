"""Route first, cluster second (issue 33): the peer of the sortie planner on maps with a battery.

What a practitioner reaches for (Beasley 1983; the split of Prins 2004): plan the mission as one
flight, as for a map without a battery (the declared pipeline), then cut that flight into
battery-sized pieces with returns to the depots, by the optimal split over the flight's order
with depot choice and ferry flights (`planner_core.fleet.split`), share the pieces among the
vehicles as consecutive chunks, and re-solve the hover times by the LP across sorties
(`planner_core.fleet.lp`). No sortie is planned on its own and no point changes sortie. The
sortie planner (`planner_core.fleet.plan_fleet`, the `sorties` entry) starts from this plan.

Cost: the single flight's pipeline plus one split (O(n x L x D^2)) and one LP.
"""

from __future__ import annotations

from typing import Any

from planner_core.fleet import FleetResult, route_first

__all__ = ["optimise_fleet"]


def optimise_fleet(m: Any, config: Any, *, goal: str | None = None, **_: Any) -> FleetResult:
    """The route-first cluster-second fleet plan of map m (with a battery) for
    `config` (a `planner_core.pipeline.PlanConfig`: seed and the single flight's budget).

    Args:
        m: a loaded map with a battery or fleet.
        config: the single flight's pipeline settings.
        goal: "total" or "makespan" (default the map's).

    Returns:
        The `planner_core.fleet.FleetResult`.

    Raises:
        ValueError: no split fits the battery.
    """
    return route_first(m, config, goal=goal)

"""How many corner slots a map needs: the `auto` rule of the product's mode (issue 31).

In the product's mode (`lamde_mission.plan`, `lamde-mission plan`) detour corners, the points of
0 s written as NAV_WAYPOINT, need not take one of the I_max slots: `Problem(corner_slots=K)`
gives the encoding K more slots while phi still allows only I_max points with t > 0. The
paper's protocol (`lamde-mission bench` and its peers) keeps K = 0, the paper's model.

The rule, `auto_corner_slots`: draw `RULE_DRAWS` of the seeder's plans (the starts the
planner builds anyway: clusters, visiting order, visibility-graph corners on blocked legs,
prune and, when the route still has more than I_max points, truncation to I_max; fixed
generators seeded 0, 1, ..., so K depends on the map alone). A plan that fits (no leg blocked,
every sensor served) needs no slots. A plan that does not fit needs, for its corners, the
corners it kept (points that serve no sensor, 0 s) plus one per leg it had to leave blocked.
K is the median of that count over the draws (it stops once most draws fit). Measured
(docs/scaling.md, "Detour corners and I_max"): all of the first five draws on each of the 16
suite maps and the 8 large maps fit or hold no corner (K = 0: the paper's Problem, the same
plans); campus-500's needed 3, 3, 4, 5, 4 (K = 3 from the first three; 4 since the
inflation is the exact outer offset, 2026-12-06).

`problem_for(...)` builds the Problem a plan runs on and its seeder (its visibility graph:
5.7 s of CPU on campus-500, ~1 min at 2,000 footprints; a `progress` callback hears how far),
and shares the seeder between the K = 0 problem the rule reads and the one with K slots.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from planner_core.defaults import MAX_CORNER_SLOTS
from planner_core.model.geometry import overlap_lengths
from planner_core.model.problem import Problem
from planner_core.model.routing.graph import CLEAR
from planner_core.model.seeding import Seeder

__all__ = ["AUTO", "MAX_CORNER_SLOTS", "RULE_DRAWS", "auto_corner_slots", "check_corner_slots",
           "corner_need", "problem_for", "slot_shortfall"]

#: the `corner_slots` value that asks for the rule
AUTO = "auto"
#: seeder plans the rule draws at most (fixed generators seeded 0 .. RULE_DRAWS - 1; it stops
#: once most of them fit: 2 draws on a map with room); odd, so the median is one draw's. Each
#: costs 4-6 ms on the suite's maps, ~90 ms on campus-500, ~0.1 s on L02, ~0.55 s on L03
RULE_DRAWS = 3


def check_corner_slots(value: Any) -> int | str:
    """`value` if it is "auto" or an integer in [0, `MAX_CORNER_SLOTS`] (then as int).

    Args:
        value: the `corner_slots` setting.

    Returns:
        "auto" or the integer.

    Raises:
        ValueError: one line, "corner_slots: must be 'auto' or an integer >= 0, got ..." or
            "corner_slots: K is more than MAX_CORNER_SLOTS, the most ...".
    """
    if isinstance(value, str) and value == AUTO:
        return AUTO
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ValueError(f"corner_slots: must be 'auto' or an integer >= 0, got {value!r}")
    if value > MAX_CORNER_SLOTS:
        raise ValueError(f"corner_slots: {int(value):,} is more than {MAX_CORNER_SLOTS}, the most "
                         "(twice the largest I_max, plus one: what the auto rule can ask for)")
    return int(value)


def slot_shortfall(problem: Problem, draws: int = RULE_DRAWS) -> list[tuple[int, int, int]]:
    """What each of `draws` seeder plans of `problem` (plan d from `np.random.default_rng(d)`)
    lacks within the I_max slots.

    Args:
        problem: the problem (its seeder, I_max slots, obstacles, sensors).
        draws: how many seeder plans.

    Returns:
        Per plan (corners, blocked, unserved): its points that serve no sensor (hover time 0),
        its legs (start -> points -> end) with length inside obstacles > `routing.graph.CLEAR`,
        and its sensors that no point serves within T_max.
    """
    return [_shortfall(problem, d) for d in range(draws)]


def _shortfall(problem: Problem, d: int) -> tuple[int, int, int]:
    """`slot_shortfall` of the seeder plan drawn from `np.random.default_rng(d)`."""
    pts, times = problem.seeder.hover_plan(np.random.default_rng(d))
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    full = np.vstack([problem.start, pts, problem.end])
    inside = overlap_lengths(full[:-1], full[1:], problem.obstacles)
    best = problem.rates(pts).max(axis=0) if len(pts) else np.zeros(len(problem.sensors))
    unserved = best * problem.t_max * (1.0 + 1e-9) < problem.required
    return (int(np.count_nonzero(np.asarray(times) == 0.0)),
            int(np.count_nonzero(inside > CLEAR)), int(np.count_nonzero(unserved)))


def corner_need(corners: int, blocked: int, unserved: int) -> int:
    """The corner slots one seeder plan asks for: 0 when it fits (no leg blocked, no sensor
    unserved), else its corners plus one per blocked leg.

    Args:
        corners: the plan's points that serve no sensor (hover time 0).
        blocked: its legs cut by obstacles.
        unserved: its sensors no point serves within T_max.

    Returns:
        The slots, >= 0.
    """
    return corners + blocked if blocked + unserved else 0


def auto_corner_slots(problem: Problem, draws: int = RULE_DRAWS) -> int:
    """The corner slots a map needs: the median `corner_need` of `slot_shortfall`'s plans,
    rounded up (module doc).

    Args:
        problem: the map's Problem with `corner_slots` 0 (the paper's encoding).
        draws: how many seeder plans the rule reads.

    Returns:
        K >= 0; 0 in fixed-length mode, with an activation threshold <= 0 (every slot flown)
        or for a map without obstacles.

    Raises:
        ValueError: `problem` already has corner slots.
    """
    if problem.corner_slots:
        raise ValueError("problem: the rule reads the paper's encoding (corner_slots 0)")
    obs = problem.obstacles
    if not problem.variable_length or problem.tau <= 0.0 \
            or obs.n_circles + obs.n_polygons == 0:
        return 0
    need: list[int] = []
    for d in range(draws):
        need.append(corner_need(*_shortfall(problem, d)))
        if need.count(0) > draws // 2:  # most plans fit: the median is 0, whatever the rest
            return 0
    return int(math.ceil(float(np.median(need))))


def problem_for(planning_map: Any, *, variable_length: bool = True,
                corner_slots: int | str = AUTO,
                progress: Callable[[float], None] | None = None) -> tuple[Problem, int]:
    """The Problem a plan runs on and its corner slots, "auto" resolved by `auto_corner_slots`.

    Its seeder (`Problem.seeder`: the visibility graph, which every default pipeline uses) is
    built here, for every K, so that a plan's setup holds the build (minutes at the obstacle
    limit), not its first stage.

    Args:
        planning_map: the planning map (`Map.planning_map()`).
        variable_length: False: every slot flown (then "auto" is 0).
        corner_slots: "auto" or K >= 0.
        progress: told the fraction of the visibility graph's build done
            (`build_visibility_graph`'s `progress`: increasing, the last call 1.0); None:
            nothing.

    Returns:
        (problem, K). With "auto" and K > 0 the problem's seeder is the rule's, with this
        problem's model (`_share_seeder`): the visibility graph is built once.

    Raises:
        ValueError: a bad `corner_slots` (one line).
    """
    k = check_corner_slots(corner_slots)
    if k != AUTO:
        problem = Problem(planning_map, variable_length=variable_length, corner_slots=k)
        _build_seeder(problem, progress)
        return problem, k
    base = Problem(planning_map, variable_length=variable_length)
    _build_seeder(base, progress)
    k = auto_corner_slots(base)
    if k == 0:
        return base, 0
    problem = Problem(planning_map, variable_length=variable_length, corner_slots=k)
    _share_seeder(base, problem)
    return problem, k


def _build_seeder(problem: Problem, progress: Callable[[float], None] | None) -> None:
    """Build `problem`'s seeder now, telling `progress` how far its visibility graph is: the
    object `Problem.seeder` would build on first use (`Seeder.for_problem`), put in the
    cached_property's slot."""
    problem.__dict__["seeder"] = Seeder.for_problem(problem, progress=progress)


def _share_seeder(base: Problem, problem: Problem) -> None:
    """Give `problem` (the same map with corner slots) `base`'s seeder with `problem`'s model.

    What `Seeder.__init__` builds from the map (visibility graph, reach, the start's and end's
    links, the C3 flags of the graph's corners) does not depend on the number of slots, which
    the seeder reads from its model when it plans; tests hold the shared seeder's starts equal
    to a fresh `Seeder.for_problem(problem)`'s.
    """
    seeder = copy.copy(base.seeder)
    seeder.p = problem.model
    problem.__dict__["seeder"] = seeder  # the cached_property's slot

"""A mission simulator independent of the optimiser: replay MAVLink items, verify C1..C5.

`replay(items, map)` flies mission items with the paper's model and returns a `Timeline`;
`verify(timeline, map)` judges it with its own shapely geometry. Nothing here imports the
optimiser (`planner_core.search.de`, `planner_core.model.problem`) nor `lamde_mission`, so the sim
is a second
opinion. `sim.mission` (items, MAVLink enums, items -> route) and `sim.geo` (ENU <-> WGS84) are
the mission vocabulary that `lamde_mission` writes plans into.
"""

from sim.checks import Verdict, Verdicts, verify
from sim.replay import Timeline, Totals, replay, replay_route

__all__ = ["Timeline", "Totals", "Verdict", "Verdicts", "replay", "replay_route", "verify"]

"""The vehicles' own speed limits against the speed a fleet's sorties ask, before sending.

PX4 flies a mission's DO_CHANGE_SPEED at most at its MPC_XY_VEL_MAX (12 m/s by default, below
the maps' default 20 m/s), so a sortie planned at 20 m/s takes longer and draws more energy
than planned. `fleet_speed_check` builds the check `upload_fleet` applies by default once it
has read every vehicle's limit and before anything is sent, and `lamde-mission upload DIR/
--fleet` applies the same check (only its hints name CLI options): a vehicle below its sortie's
speed is refused when the sortie was planned with a battery (fleet.json gives an energy the
limit makes unchecked; a map re-checks it), warned about when it was planned without one (or is
no sortie of a directory: no planned energy is known), and with a map the whole directory is
judged once with each vehicle at its own limit (`sorties.verify_sortie_dir`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

if TYPE_CHECKING:
    from lamde_mission.formats.fleet import FleetSortie
    from lamde_mission.items import MissionItem
    from lamde_mission.vehicle.fleet import FleetMission
    from planner_core.model.mapio import Map

__all__ = ["SpeedLimitWarning", "SpeedHints", "API_HINTS", "CLI_HINTS", "asked_speed",
           "planned_energy", "unflyable_limit", "fleet_speed_check"]  # fmt: skip

#: what `fleet_speed_check`'s check takes: {vehicle (1-based): (parameter, m/s), or None when
#: its limit could not be read}
Limits = Mapping[int, "tuple[str, float] | None"]


class SpeedLimitWarning(UserWarning):
    """A vehicle's speed limit is below the speed its mission asks and the mission is sent
    anyway (no battery planned, or the check was told to send), or its limit was not read."""


class SpeedHints(NamedTuple):
    """How the messages name the two ways on: judging on the map, and sending anyway."""

    #: what judges the directory on the map at the vehicles' limits
    map: str
    #: what sends despite a refusal
    force: str


#: the words of the Python API (`fleet_speed_check`'s own arguments)
API_HINTS = SpeedHints("fleet_speed_check(..., map=MAP)", "fleet_speed_check(..., force=True)")
#: the words of `lamde-mission upload DIR/ --fleet`
CLI_HINTS = SpeedHints("--map MAP", "--force")


def asked_speed(mission: Sequence[MissionItem]) -> float | None:
    """The fastest cruise speed a mission asks for; O(items).

    Args:
        mission: its items.

    Returns:
        The largest DO_CHANGE_SPEED speed above 0, m/s, or None when it sets none.
    """
    from lamde_mission.items import CMD

    asked = [float(it.param2) for it in mission
             if it.command == CMD.DO_CHANGE_SPEED and it.param2 > 0]  # fmt: skip
    return max(asked) if asked else None


def unflyable_limit(what: str, name: str, limit: float) -> str | None:
    """The refusal when a vehicle's speed limit is no speed a mission can be flown at.

    Args:
        what: the mission or directory, for the message.
        name: the limit's parameter (MPC_XY_VEL_MAX).
        limit: its value, m/s.

    Returns:
        The refusal line when `limit` is below the sim's least mission speed or not finite,
        else None.
    """
    from planner_core.textio import printable
    from sim.mission import MIN_MISSION_SPEED

    if math.isfinite(limit) and limit >= MIN_MISSION_SPEED:
        return None
    return (f"{printable(what)}: the vehicle's {name} is {limit:g} m/s, not a speed a mission "
            f"can be flown at (at least {MIN_MISSION_SPEED:g} m/s): set {name} on the vehicle; "
            "nothing sent")


def planned_energy(s: FleetSortie | None, asked: float) -> str:
    """What fleet.json says a sortie was planned to spend, in a few words ("14.33 Wh planned
    at 20 m/s, 0.27 Wh above the reserve").

    Args:
        s: the sortie as fleet.json gives it (None: not listed there).
        asked: the speed it was planned at, m/s.

    Returns:
        The words; without figures where fleet.json gives none.
    """
    if s is None or s.energy_wh is None:
        return f"fleet.json gives no energy planned at {asked:g} m/s"
    slack = ("" if s.above_reserve_wh is None
             else f", {s.above_reserve_wh:.2f} Wh above the reserve")  # fmt: skip
    return f"{s.energy_wh:.2f} Wh planned at {asked:g} m/s{slack}"


def _default_warn(line: str) -> None:
    warnings.warn(line, SpeedLimitWarning, stacklevel=4)


def fleet_speed_check(
    missions: Sequence[FleetMission],
    *,
    directory: str | Path | None = None,
    map: Map | Callable[[], Map] | None = None,  # noqa: A002 (the word of the CLI and docs)
    map_label: str | None = None,
    force: bool = False,
    warn: Callable[[str], None] | None = None,
    note: Callable[[str], None] | None = None,
    hints: SpeedHints = API_HINTS,
) -> Callable[[Limits], str | None]:
    """The check of the vehicles' speed limits `upload_fleet` applies by default (its
    `speed_check`), and `upload DIR/ --fleet` with CLI_HINTS.

    A vehicle whose limit is below the fastest speed its mission asks (`asked_speed`) flies
    at its limit. Without a map: refused when its sortie was planned with a battery
    (`FleetMission.sortie` from fleet.json giving an energy, or giving none without saying
    `"energy_wh": null`): its energy at the limit is unchecked, and a sortie directory does
    not hold the map's energy model to check it; a warning when it was planned without a
    battery, or is no sortie of a directory (no planned energy known, as for a single
    mission). With a map the whole directory is judged once as `verify MAP DIR/` does with
    each such vehicle at its own limit (its slower sorties also moving its later take-offs):
    a note when every check holds, else refused. `force` turns each refusal into a warning.
    A limit that could not be read gets a warning; one no mission can be flown at is refused.

    Args:
        missions: the missions being sent (`vehicle.fleet.sortie_missions`, or made by hand).
        directory: the sortie directory (None: the one the missions' sorties lie in, if any).
        map: the map to judge the directory on at the limits, or a function returning it
            (called only when a vehicle is below its speed); None judges without a map.
        map_label: the map in messages (None: its name).
        force: warn and send instead of refusing.
        warn: receives each warning, one line (None: `warnings.warn` with SpeedLimitWarning).
        note: receives the note that every check holds on the map at the limits (None:
            dropped).
        hints: how the messages name the map and force (API_HINTS, CLI_HINTS).

    Returns:
        `check(limits)`: None to send, else the refusal line (nothing is sent to any
        vehicle). Without a map O(vehicles); judging on the map replays every sortie,
        O(sorties x legs).

    Raises:
        ValueError: a map without a sortie directory to judge.
    """
    from planner_core.textio import printable

    say = warn if warn is not None else _default_warn
    if directory is None:
        folders = {fm.sortie.path.parent for fm in missions if fm.sortie is not None}
        directory = next(iter(folders)) if len(folders) == 1 else None
    if map is not None and directory is None:
        raise ValueError("map: judging at the vehicles' limits needs the sortie directory "
                         "(directory=, or missions from sortie_missions)")  # fmt: skip
    where = printable(str(directory)) if directory is not None else "the fleet"
    asked = {fm.vehicle: asked_speed(fm.mission) for fm in missions if fm.mission}
    by_vehicle = {fm.vehicle: fm for fm in missions if fm.mission}

    def check(limits: Limits) -> str | None:
        for v, got in sorted(limits.items()):
            if got is None:
                say(f"{where} vehicle {v}: its speed limit could not be read: its sorties' "
                    "speed is not checked against it")  # fmt: skip
                continue
            bad = unflyable_limit(f"{where} vehicle {v}", *got)
            if bad is not None:
                return bad
        slow = {v: got for v, got in limits.items()
                if got is not None and asked.get(v) is not None and got[1] < asked[v]}
        if not slow:
            return None
        names = ", ".join(f"vehicle {v} {name} {lim:g} m/s" for v, (name, lim) in
                          sorted(slow.items()))  # fmt: skip
        want = max(asked[v] for v in slow)
        head = (f"{where}: {names}, below the {want:g} m/s the sorties ask (DO_CHANGE_SPEED), "
                "so they fly at their limits")
        fix = (f"set the limit to {want:g} or more, or plan the map with uav.max_speed "
               f"{min(lim for _, lim in slow.values()):g}")
        if map is None:
            battery = {v: by_vehicle[v] for v in sorted(slow)
                       if by_vehicle[v].sortie is not None
                       and not by_vehicle[v].sortie.no_battery}  # fmt: skip
            if not battery:  # planned without a battery, or no planned energy known
                say(f"{head}; their flight times, and the vehicles' separation and take-off "
                    f"times, were planned at {want:g} m/s ({hints.map} checks the fleet at the "
                    f"limits; {fix})")  # fmt: skip
                return None
            what = "; ".join(f"vehicle {v}'s {printable(fm.source)}: "
                             f"{planned_energy(fm.sortie, asked[v])}"
                             for v, fm in battery.items())  # fmt: skip
            unchecked = (f"{head}, and their energy at those speeds is unchecked ({what}; the "
                         "sortie directory does not hold the map's energy model)")
            if force:
                say(f"{unchecked}; sent anyway ({hints.force}; {hints.map} checks every sortie "
                    "at the vehicles' limits)")  # fmt: skip
                return None
            return (f"{unchecked}: nothing sent to any vehicle ({hints.map} re-checks every "
                    f"sortie at the vehicles' limits; or {fix}; {hints.force} sends it anyway)")
        from lamde_mission.sorties import verify_sortie_dir

        m = map() if callable(map) else map
        label = printable(map_label if map_label is not None else m.name)
        judged = verify_sortie_dir(m, directory, {v: lim for v, (_, lim) in slow.items()})
        if judged.passed:
            if note is not None:
                spans = ", ".join(f"vehicle {v}'s makespan {judged.makespan(v):.0f} s"
                                  for v in sorted(slow))  # fmt: skip
                note(f"{head}: {spans}; every check holds at those speeds on {label}")
            return None
        lines = "; ".join(printable(x) for x in judged.failed())
        if force:
            say(f"{head}, and at those speeds the simulator rejects the fleet on {label} "
                f"({lines}); sent anyway ({hints.force})")
            return None
        return (f"{head}, and at those speeds the simulator rejects the fleet on {label}: "
                f"{lines}; nothing sent to any vehicle ({fix}; {hints.force} sends it anyway)")

    return check

"""The vehicles' own speed limits against the speed a mission or a fleet's sorties ask, before
sending.

PX4 flies a mission's DO_CHANGE_SPEED at most at its MPC_XY_VEL_MAX (12 m/s by default, below
the maps' default 20 m/s), so a sortie planned at 20 m/s takes longer and draws more energy
than planned. `mission_speed_check` builds the check `upload_mission` applies by default once
it has read the vehicle's limit and before anything is sent, and `lamde-mission upload
MISSION` applies the same check; `fleet_speed_check` is `upload_fleet`'s, and `lamde-mission
upload DIR/ --fleet`'s (only the hints name CLI options, `MISSION_CLI_HINTS`, `CLI_HINTS`). A
vehicle below its mission's speed is refused when the mission is a sortie planned with a
battery (fleet.json gives an energy the limit makes unchecked; a map re-checks it), warned
about when it was planned without one (or is no sortie of a directory: no planned energy is
known), and with a map the mission is replayed and judged at the limit (a fleet's whole
directory once, with each vehicle at its own limit: `sorties.verify_sortie_dir`).
"""

from __future__ import annotations

import functools
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

__all__ = ["SpeedLimitWarning", "SpeedHints", "API_HINTS", "CLI_HINTS", "MissionHints",
           "MISSION_API_HINTS", "MISSION_CLI_HINTS", "asked_speed", "planned_energy",
           "unflyable_limit", "sortie_with_battery", "mission_speed_check",
           "fleet_speed_check"]  # fmt: skip

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


class MissionHints(NamedTuple):
    """How a single mission's messages name the ways on: judging it on the map, sending
    anyway, and (a sortie of a directory) judging the whole directory at the limits."""

    #: what judges the mission on the map at the vehicle's limit
    map: str
    #: what sends despite a refusal
    force: str
    #: what checks every sortie of the directory "{dir}" at the vehicles' limits, a clause
    fleet: str


#: the words of the Python API (`mission_speed_check`'s arguments, `sorties.verify_sortie_dir`)
MISSION_API_HINTS = MissionHints(
    "mission_speed_check(..., map=MAP)", "mission_speed_check(..., force=True)",
    "`sorties.verify_sortie_dir(MAP, '{dir}', {vehicle: limit})` checks every sortie at the "
    "vehicles' limits",
)  # fmt: skip
#: the words of `lamde-mission upload MISSION`
MISSION_CLI_HINTS = MissionHints(
    "--map", "--force",
    "`lamde-mission upload {dir}/ --fleet --map MAP` checks every sortie at the vehicles' limits",
)  # fmt: skip


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


def sortie_with_battery(path: str | Path, asked: float) -> tuple[str, Path] | None:
    """For a mission file that is a sortie of a sortie directory (`sorties.sortie_dir_of`)
    planned with a battery: its planned energy in words and the directory. A sortie that
    fleet.json does not list, or a fleet.json that cannot be read, counts as planned with a
    battery. O(vehicles + sorties).

    Args:
        path: the mission file.
        asked: the speed it was planned at, m/s.

    Returns:
        (words, directory), or None: no sortie of a directory, or fleet.json says
        `"energy_wh": null` for it (a map without a battery).
    """
    from lamde_mission.formats.fleet import FleetDirError, read_fleet_dir
    from lamde_mission.sorties import sortie_dir_of

    folder = sortie_dir_of(path)
    if folder is None:
        return None
    try:
        fleet = read_fleet_dir(folder)
    except FleetDirError:  # its reader's refusal comes from the upload itself
        planned = {}
    else:
        planned = {s.path.name: s for v in fleet.vehicles for s in v.sorties}
    s = planned.get(Path(path).name)
    if s is not None and s.no_battery:
        return None
    return planned_energy(s, asked), folder


def _default_warn(line: str, stacklevel: int = 4) -> None:
    warnings.warn(line, SpeedLimitWarning, stacklevel=stacklevel)


def mission_speed_check(
    mission: Sequence[MissionItem],
    *,
    source: str | Path | None = None,
    map: Map | Callable[[], Map] | None = None,  # noqa: A002 (the word of the CLI and docs)
    map_label: str | None = None,
    force: bool = False,
    warn: Callable[[str], None] | None = None,
    note: Callable[[str], None] | None = None,
    hints: MissionHints = MISSION_API_HINTS,
) -> Callable[[str, float], str | None]:
    """The check of the vehicle's speed limit `upload_mission` applies by default (its
    `speed_check`, `speed_check(parameter, limit)` once the limit is read, before anything is
    sent), and `lamde-mission upload MISSION` with MISSION_CLI_HINTS.

    A limit no mission can be flown at is refused. Below the fastest speed the mission asks
    (`asked_speed`) it flies at the limit. Without a map: refused when `source` is a sortie of
    a sortie directory planned with a battery (`sortie_with_battery`): its energy at the
    limit is unchecked, and the directory does not hold the map's energy model to check it;
    else a warning (no battery known: bare items, a standalone file, a sortie planned without
    a battery). With a map the mission is replayed at the limit and judged as `verify` does: a
    note (its longer flight) when every check holds, else refused. `force` turns each refusal
    into a warning.

    Args:
        mission: the mission being sent (its items, type MISSION).
        source: the file it was read from, whose folder's fleet.json says whether it is a
            sortie planned with a battery (for `vehicle.fleet.sortie_missions`' missions
            `fm.sortie.path`; `fm.source` is the bare file name); named in the messages.
            None: no battery known, "the mission" in the messages.
        map: the map to replay it on at the limit (with an origin to place its items), or a
            function returning it (called only when the limit is below the mission's speed);
            None judges without a map.
        map_label: the map in messages (None: its name).
        force: warn and send instead of refusing.
        warn: receives each warning, one line (None: `warnings.warn` with SpeedLimitWarning).
        note: receives the note that every check holds on the map at the limit (None:
            dropped).
        hints: how the messages name the map, force and the directory's check
            (MISSION_API_HINTS, MISSION_CLI_HINTS).

    Returns:
        `check(parameter, limit m/s)`: None to send, else the refusal line (nothing is sent).
        Without a map O(1) after an O(items) pass here (a sortie's fleet.json read,
        O(vehicles + sorties)); with a map the mission is replayed twice, O(legs).

    Raises:
        ValueError: `source` is no file (a bare name would silently find no battery).
    """
    from planner_core.textio import printable

    if source is not None and not Path(source).is_file():
        raise ValueError(f"source: {printable(str(source))} is no file (the mission's file: "
                         "its folder's fleet.json says whether it was planned with a battery)")
    # warnings.warn <- check <- transfer.upload_and_verify <- upload_mission <- its caller
    say = warn if warn is not None else functools.partial(_default_warn, stacklevel=5)
    what = str(source) if source is not None else "the mission"
    asked = asked_speed(mission)

    def check(name: str, limit: float) -> str | None:
        bad = unflyable_limit(what, name, limit)
        if bad is not None:
            return bad
        if asked is None or limit >= asked:
            return None
        head = (f"{printable(what)}: the vehicle's {name} is {limit:g} m/s, below the "
                f"{asked:g} m/s the mission asks (DO_CHANGE_SPEED), so it flies at "
                f"{limit:g} m/s")  # fmt: skip
        fix = f"set {name} to {asked:g} or more, or plan the map with uav.max_speed {limit:g}"
        if map is None:
            unchecked = None if source is None else sortie_with_battery(source, asked)
            if unchecked is None:  # no battery known: no energy to check
                say(f"{head}; its flight time and energy were planned at {asked:g} m/s "
                    f"({hints.map} checks it at {limit:g} m/s; {fix})")  # fmt: skip
                return None
            planned, folder = unchecked
            line = (f"{head}, and its energy at that speed is unchecked (a sortie of "
                    f"{printable(str(folder))}/, {planned})")
            again = hints.fleet.replace("{dir}", printable(str(folder)))
            if force:
                say(f"{line}; sent anyway ({hints.force}; {again})")
                return None
            return f"{line}: nothing sent ({again}; or {fix}; {hints.force} sends it anyway)"
        from sim import replay, verify

        m = map() if callable(map) else map
        label = printable(map_label if map_label is not None else m.name)
        slow, planned_flight = replay(mission, m, speed_limit=limit), replay(mission, m)
        failed = [printable(f"{v.name} {v.title}: FAIL, margin {v.margin:.4g} {v.unit}; "
                            f"{v.detail}") for v in verify(slow, m) if not v.passed]  # fmt: skip
        if not failed:
            if note is not None:
                note(f"{head}: t_fly {slow.totals.t_fly:.0f} s instead of "
                     f"{planned_flight.totals.t_fly:.0f} s; every check holds at that speed on "
                     f"{label}")  # fmt: skip
            return None
        lines = "; ".join(failed)
        if force:
            say(f"{head}, and at that speed the simulator rejects it on {label} ({lines}); "
                f"sent anyway ({hints.force})")
            return None
        return (f"{head}, and at that speed the simulator rejects it on {label}: {lines}; "
                f"nothing sent ({fix}; {hints.force} sends it anyway)")

    return check


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

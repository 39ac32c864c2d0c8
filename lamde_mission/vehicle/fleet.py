"""Upload a fleet: each vehicle its own mission, addressed by its MAVLink system id.

`upload_fleet` sends mission k to vehicle k and reads it back, as `upload_mission` does for one
vehicle, over one connection several vehicles share (a multi-vehicle radio, a MAVLink router,
every PX4 SITL instance on QGroundControl's port) or one connection per vehicle (PX4 SITL's
offboard ports 14540 + i, a radio each). Vehicle k is the vehicle with system id
`system_ids[k]`; without them, on one connection the vehicles heard there in ascending system
id, on one connection each the vehicle heard on it.

Before anything is sent, `survey` listens to every connection at once for the vehicles'
HEARTBEATs (at least `claims.HEARTBEAT_WATCH_S`, at most `timeout`): a vehicle that does not
answer, a count that differs from the missions', or two autopilots claiming one system id from
two addresses stop it with nothing sent (`FleetSurveyError`, `DuplicateVehicleError`). The
uploads then run one vehicle after the other, each through its own client pinned to its system
id (MAVSDK through a relay that passes it that system only: one MAVSDK per vehicle, as MAVSDK's
maintainers advise for several vehicles on one stream, mavlink/MAVSDK-Python issue 685); each
client starts sending once it hears its vehicle, the survey having done the listening. A failed
vehicle does not stop the others; the report says which went up. Cost: O(vehicles) transfers,
each as `upload_mission`'s.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from lamde_mission.items import MissionItem
from lamde_mission.vehicle.claims import ClaimWatch, duplicate_error
from lamde_mission.vehicle.connection import Connection, Link, parse_connection, parse_connections
from lamde_mission.vehicle.transfer import (
    DuplicateVehicleError,
    SpeedLimitError,
    UploadReport,
    VehicleError,
)
from planner_core.textio import counted, for_count

if TYPE_CHECKING:
    from lamde_mission.formats.fleet import FleetSortie

__all__ = ["first_sortie_missions", "sortie_missions", "FleetSetupError", "FleetSurveyError",
           "FleetMission",
           "VehicleResult", "FleetReport", "survey", "assign_system_ids",
           "upload_fleet"]  # fmt: skip


class FleetSetupError(ValueError):
    """The vehicles do not match the missions (a vehicle missing, a count that differs, a
    connection or id list of the wrong length): nothing was uploaded. One line. The CLI's exit
    status 2 (bad input) for a list of the wrong length or an id out of range; a
    `FleetSurveyError` (what the link answered) is 1."""


class FleetSurveyError(FleetSetupError):
    """What the survey heard does not match the missions: a vehicle (or system id) not heard
    within the timeout, or more or fewer vehicles answering than there are missions. Nothing
    was uploaded. The link, not the command, is at fault (a vehicle off or out of range, a
    radio down), so the CLI exits with status 1, as a single upload does when no vehicle
    answers. One line."""


@dataclass(frozen=True)
class FleetMission:
    """What vehicle `vehicle` (1-based) gets: its mission, fence (None: left alone) and rally
    points (None: left alone), the file they came from (for the report) and, for a sortie of
    a sortie directory, the sortie as fleet.json gives it (its energy and battery, for the
    speed-limit check, `speeds.fleet_speed_check`; None: made by hand). An empty mission
    sends nothing to that vehicle (a vehicle the plan gives no sortie), though it is still
    surveyed and counted."""

    vehicle: int
    mission: Sequence[MissionItem]
    fence: Sequence[MissionItem] | None = ()
    rally: Sequence[MissionItem] | None = None
    source: str = ""
    sortie: FleetSortie | None = None


@dataclass
class VehicleResult:
    """One vehicle's upload: where, which system id, and the report or the error."""

    vehicle: int
    system_id: int
    connect: str
    source: str
    report: UploadReport | None = None
    error: VehicleError | None = None
    #: nothing to send (the plan gives this vehicle no sortie)
    skipped: bool = False

    @property
    def ok(self) -> bool:
        """Whether the vehicle holds its mission, read back identical (or had none to get).

        Returns:
            True when the report is ok and there is no error; for a skipped vehicle, when
            there is no error.
        """
        if self.skipped:
            return self.error is None
        return self.report is not None and self.report.ok and self.error is None

    def lines(self) -> list[str]:
        """This vehicle's part of the report: a head line, the upload's lines indented.

        Returns:
            The head line, then the report's (or the error's report's) lines indented and a
            "FAILED: ..." line on an error; one line for a skipped vehicle.
        """
        head = f"vehicle {self.vehicle} (system {self.system_id} at {self.connect}, {self.source})"
        if self.skipped:
            return [f"{head}: no sortie planned, nothing sent"]
        out = [f"{head}:"]
        rep = self.report if self.report is not None else getattr(self.error, "report", None)
        if rep is not None:
            out.extend(f"  {line}" for line in rep.lines())
        if self.error is not None:
            out.append(f"  FAILED: {self.error}")
        return out


@dataclass
class FleetReport:
    """Every vehicle's result, the survey's time (s) and the whole time (s)."""

    results: list[VehicleResult] = field(default_factory=list)
    survey_s: float = 0.0
    total_s: float = 0.0

    @property
    def ok(self) -> bool:
        """Whether every vehicle's result is ok.

        Returns:
            True when there are results and each is ok.
        """
        return bool(self.results) and all(r.ok for r in self.results)

    def lines(self) -> list[str]:
        """The report `lamde-mission upload --fleet` prints: each vehicle's lines, then one
        summary line.

        Returns:
            The lines, without newlines.
        """
        return [line for r in self.results for line in r.lines()] + [self.summary()]

    def summary(self) -> str:
        """The last line: how many vehicles hold their mission, and the times.

        Returns:
            The line: vehicles sent to and holding their mission, the survey's and the whole
            time (s), the vehicles without this sortie, and a pointer to FAILED lines.
        """
        sent = [r for r in self.results if not r.skipped]
        good = sum(r.ok for r in sent)
        n = len(sent)
        idle = len(self.results) - n
        return (
            f"fleet: {good} of {counted(n, 'vehicle')} "
            f"{for_count(good, 'holds its', 'hold their')} mission, read back identical "
            f"(survey {self.survey_s:.2f} s, all {self.total_s:.2f} s)"
            + (f"; {idle} without this sortie, nothing sent" if idle else "")
            + ("" if good == n else "; the others: see FAILED above")
        )


def first_sortie_missions(directory: str | Path) -> list[FleetMission]:
    """Each vehicle's first sortie of a sortie directory, read as `upload_fleet` takes them
    (`sortie_missions(directory, 1)`).

    Args:
        directory: a sortie directory (`formats.fleet.read_fleet_dir`).

    Returns:
        One FleetMission per vehicle of fleet.json, in vehicle order (an empty mission for a
        vehicle without sorties); `source` is the file's name.

    Raises:
        FleetDirError: a bad directory or fleet.json (one line naming the field).
        MissionFileError: a sortie file that cannot be read, or holds no mission item.
    """
    return sortie_missions(directory, 1)


def sortie_missions(directory: str | Path, sortie: int) -> list[FleetMission]:
    """Each vehicle's sortie number `sortie` of a sortie directory (after `sortie` - 1 battery
    swaps), read as `upload_fleet` takes them.

    Args:
        directory: a sortie directory (`formats.fleet.read_fleet_dir`).
        sortie: the sortie's number, 1-based.

    Returns:
        One FleetMission per vehicle of fleet.json, in vehicle order (an empty mission, sent to
        no one, for a vehicle with fewer sorties); `source` is the file's name, `sortie` its
        entry in fleet.json.

    Raises:
        ValueError: `sortie` below 1, or no vehicle flies that many sorties.
        FleetDirError: a bad directory or fleet.json (one line naming the field).
        MissionFileError: a sortie file that cannot be read, or holds no mission item.
    """
    from lamde_mission.formats import MissionFileError, read_mission_lists
    from lamde_mission.formats.fleet import read_fleet_dir

    if int(sortie) < 1:
        raise ValueError(f"sortie must be 1 or more, got {sortie}")
    fleet = read_fleet_dir(directory)
    chosen = fleet.sorties_numbered(int(sortie))
    if all(s is None for s in chosen):
        most = max(len(v.sorties) for v in fleet.vehicles)
        raise ValueError(f"{fleet.path}: no vehicle flies a sortie {sortie} (the most sorties "
                         f"of a vehicle: {most})")  # fmt: skip
    out = []
    for v, first in zip(fleet.vehicles, chosen, strict=True):
        if first is None:
            out.append(FleetMission(v.vehicle, [], source=f"no sortie {sortie}"))
            continue
        mission, fence, rally = read_mission_lists(first.path)
        if not mission:
            raise MissionFileError(f"{first.path}: the mission holds no items")
        out.append(FleetMission(v.vehicle, mission, fence, rally or None, first.path.name,
                                first))
    return out


def _heard_line(heard: Sequence[int]) -> str:
    if not heard:
        return "no vehicle heard"
    return f"heard {for_count(len(heard), 'system')} {', '.join(str(x) for x in heard)}"


def survey(
    connections: Sequence[str | Connection],
    *,
    timeout: float,
    want: Callable[[list[list[int]]], bool],
    window: float | None = None,
    signing_key: bytes | None = None,
) -> list[list[int]]:
    """Listen to every connection at once for vehicles' HEARTBEATs (component 1, an
    autopilot's). Only the ground station's own HEARTBEAT goes out, once a second on each link
    that has somewhere to send (a vehicle listening with udpin answers whoever wrote to it,
    as for `upload_mission`); nothing that changes a vehicle.

    Args:
        connections: the links (`connection.parse_connection` strings or Connections).
        timeout: the most seconds to listen.
        want: `want(heard)` True once enough is heard (heard: per connection, the system ids
            in ascending order); listening stops then, but not before `window` s.
        window: the least seconds to listen (None: `claims.HEARTBEAT_WATCH_S`, one HEARTBEAT
            from every autopilot at 1 Hz).
        signing_key: hear only messages signed with this key.

    Returns:
        Per connection, the system ids heard there, ascending.

    Raises:
        DuplicateVehicleError: one system id claimed from two addresses on one link.
        VehicleError: a link cannot be opened.
    """
    from pymavlink.dialects.v20 import common as mavlink2

    from lamde_mission.vehicle.claims import is_vehicle_heartbeat

    conns = [c if isinstance(c, Connection) else parse_connection(c) for c in connections]
    links: list[Link] = []
    try:
        for c in conns:
            try:
                links.append(Link(c))
            except OSError as exc:
                raise VehicleError(f"cannot open {c}: {exc.strerror or exc}") from None
        parsers = []
        for _ in links:
            mav = mavlink2.MAVLink(
                None, srcSystem=255, srcComponent=mavlink2.MAV_COMP_ID_MISSIONPLANNER
            )
            mav.robust_parsing = True
            if signing_key is not None:
                from lamde_mission.vehicle.signing import enable_signing

                enable_signing(mav, signing_key)
            parsers.append(mav)
        watches = [ClaimWatch(window) for _ in links]
        window = watches[0].window_s if watches else 0.0  # None: the watch's default
        first: list[dict[int, tuple[str, int] | None]] = [{} for _ in links]
        t0 = time.monotonic()
        next_beat = t0
        beat = mavlink2.MAVLink_heartbeat_message(
            mavlink2.MAV_TYPE_GCS,
            mavlink2.MAV_AUTOPILOT_INVALID,
            0,
            0,
            mavlink2.MAV_STATE_ACTIVE,
            3,
        )
        while True:
            heard = [sorted(f) for f in first]
            now = time.monotonic()
            if now - t0 >= timeout or (now - t0 >= window and want(heard)):
                return heard
            if now >= next_beat:  # the ground station's HEARTBEAT, as both uploaders send it
                next_beat = now + 1.0
                for k, link in enumerate(links):
                    with contextlib.suppress(OSError):
                        link.send(beat.pack(parsers[k]))
                    parsers[k].seq = (parsers[k].seq + 1) % 256
            for k, link in enumerate(links):
                for data, addr in link.recv(0.02):
                    for msg in parsers[k].parse_buffer(data) or []:
                        if msg.get_type() == "BAD_DATA" or not is_vehicle_heartbeat(msg):
                            continue
                        watches[k].note(msg, addr)
                        sid = msg.get_srcSystem()
                        pinned = first[k].setdefault(sid, addr)
                        other = watches[k].conflict((sid, 1), pinned)
                        if other is not None and pinned is not None:
                            raise duplicate_error((sid, 1), pinned, other, sent=False)
    finally:
        for link in links:
            link.close()


def assign_system_ids(
    n: int,
    connections: Sequence[str],
    system_ids: Sequence[int] | None,
    *,
    timeout: float,
    window: float | None = None,
    signing_key: bytes | None = None,
) -> tuple[list[str], list[int], float]:
    """Which connection and system id each of `n` vehicles has, checked by listening.

    Args:
        n: the number of vehicles (missions).
        connections: one for all, or one per vehicle.
        system_ids: one per vehicle, or None (from the HEARTBEATs: on one connection the
            vehicles heard in ascending system id, on one each the one vehicle heard there).
        timeout: the most seconds to listen for the vehicles.
        window: the least seconds to listen.
        signing_key: hear only messages signed with it.

    Returns:
        (connection per vehicle, system id per vehicle, seconds listened).

    Raises:
        FleetSetupError: a list of the wrong length, an id twice on one link.
        FleetSurveyError: a vehicle missing, more or fewer vehicles than missions, two
            vehicles on a one-vehicle link.
        DuplicateVehicleError: one system id from two addresses.
    """
    conns = list(connections)
    if len(conns) not in (1, n):
        raise FleetSetupError(f"--connect: {counted(len(conns), 'connection')} for "
                              f"{counted(n, 'vehicle')} (give one connection for all, or one "
                              "per vehicle)")  # fmt: skip
    shared = len(conns) == 1 and n > 1
    if system_ids is not None:
        ids = [int(s) for s in system_ids]
        if len(ids) != n:
            raise FleetSetupError(f"--sysid: {counted(len(ids), 'system id')} for "
                                  f"{counted(n, 'vehicle')} (give one per vehicle, in vehicle "
                                  "order)")  # fmt: skip
        for s in ids:
            if not 1 <= s <= 255:
                raise FleetSetupError(f"--sysid: {s} is not a MAVLink system id (1..255)")
        if shared and len(set(ids)) != n:
            dup = sorted({s for s in ids if ids.count(s) > 1})
            raise FleetSetupError(f"--sysid: system id {dup[0]} given twice for one connection "
                                  "(each vehicle on it needs its own)")  # fmt: skip
    else:
        ids = None

    def want(heard: list[list[int]]) -> bool:
        if ids is not None:
            if shared:
                return set(ids) <= set(heard[0])
            return all(ids[k] in heard[k] for k in range(n))
        if shared:
            return len(heard[0]) >= n
        return all(len(h) >= 1 for h in heard)

    t0 = time.monotonic()
    heard = survey(conns, timeout=timeout, want=want, window=window, signing_key=signing_key)
    listened = time.monotonic() - t0
    if shared:
        got = heard[0]
        if ids is not None:
            missing = [s for s in ids if s not in got]
            if missing:
                k = ids.index(missing[0]) + 1
                raise FleetSurveyError(
                    f"vehicle {k}: no HEARTBEAT from system {missing[0]} at {conns[0]} within "
                    f"{timeout:g} s ({_heard_line(got)}); nothing was uploaded"
                )
            return [conns[0]] * n, ids, listened
        if len(got) != n:
            raise FleetSurveyError(
                f"{counted(n, 'mission')} but {counted(len(got), 'vehicle')} "
                f"{for_count(len(got), 'answers', 'answer')} at {conns[0]} "
                f"({_heard_line(got)}, listened {listened:.1f} s); nothing was uploaded (--sysid "
                "names the vehicles to use)"
            )
        return [conns[0]] * n, list(got), listened
    out = []
    for k in range(n):
        got = heard[k]
        if ids is not None:
            if ids[k] not in got:
                raise FleetSurveyError(
                    f"vehicle {k + 1}: no HEARTBEAT from system {ids[k]} at {conns[k]} within "
                    f"{timeout:g} s ({_heard_line(got)}); nothing was uploaded"
                )
            out.append(ids[k])
        elif not got:
            raise FleetSurveyError(f"vehicle {k + 1}: no vehicle heard at {conns[k]} within "
                                  f"{timeout:g} s; nothing was uploaded")  # fmt: skip
        elif len(got) > 1:
            raise FleetSurveyError(
                f"vehicle {k + 1}: {len(got)} vehicles answer at {conns[k]} "
                f"({_heard_line(got)}); nothing was uploaded (--sysid says which is "
                f"vehicle {k + 1})"
            )
        else:
            out.append(got[0])
    return conns, out, listened


def _read_speed_limits(
    missions: Sequence[FleetMission], conns: Sequence[Any], ids: Sequence[int], *, via: str,
    timeout: float, autopilot: str | None, signing_key: bytes | None,
    log: Callable[[str], None] | None,
) -> dict[int, tuple[str, float] | None]:
    """Each vehicle's horizontal speed limit, read before anything is sent (`upload_fleet`'s
    speed_check): a short connection of its own per vehicle with a mission, the parameter of
    its dialect (`transfer.speed_limit_param`; the HEARTBEAT's autopilot unless `autopilot`,
    none read when the HEARTBEAT names another autopilot than `autopilot`).

    Returns:
        {vehicle: (parameter, m/s), or None when it did not answer or could not be reached}
        for the vehicles whose dialect has such a parameter.
    """
    from lamde_mission.storage import dialect_for_autopilot, dialect_of
    from lamde_mission.vehicle.transfer import PARAM_TIMEOUT_S, speed_limit_param
    from lamde_mission.vehicle.upload import make_client

    out: dict[int, tuple[str, float] | None] = {}
    for fm, conn, sid in zip(missions, conns, ids, strict=True):
        if not fm.mission:
            continue
        client = make_client(via, conn, log=log, signing_key=signing_key, heartbeat_watch=0.0,
                             system_id=sid)  # fmt: skip
        try:
            info = client.connect(timeout)
            heard = dialect_for_autopilot(info.autopilot)
            dialect = dialect_of(autopilot) if autopilot is not None else heard
            name = speed_limit_param(dialect, heard)
            if name is not None:
                value = client.read_param(name, min(timeout, PARAM_TIMEOUT_S))
                out[fm.vehicle] = None if value is None else (name, float(value))
        except VehicleError:
            out[fm.vehicle] = None  # the upload itself says what is wrong with the link
        finally:
            client.close()
    return out


def upload_fleet(
    missions: Sequence[FleetMission],
    *,
    connect: Sequence[str] = ("udpin://0.0.0.0:14540",),
    system_ids: Sequence[int] | None = None,
    via: str = "mavsdk",
    timeout: float = 30.0,
    attempts: int = 3,
    autopilot: str | None = None,
    signing_key: bytes | None = None,
    log: Callable[[str], None] | None = None,
    progress: Callable[[str, int, int], None] | None = None,
    on_vehicle: Callable[[VehicleResult], None] | None = None,
    window: float | None = None,
    speed_check: (Callable[[dict[int, tuple[str, float] | None]], str | None] | None
                  | Literal["planned"]) = "planned",
) -> FleetReport:
    """Upload mission k to vehicle k, read each back and compare (see the module docstring).

    Args:
        missions: one per vehicle, in vehicle order (`FleetMission.vehicle` 1..n).
        connect: one connection for all vehicles, or one per vehicle.
        system_ids: the vehicles' MAVLink system ids, in vehicle order (None: from their
            HEARTBEATs).
        via: "mavsdk" or "pymavlink" (`upload.make_client`).
        timeout: seconds to wait for the vehicles, and without progress in a transfer.
        attempts: whole-transfer retries per vehicle (`transfer.upload_and_verify`).
        autopilot: storage rules (px4, ardupilot, generic; None: each vehicle's HEARTBEAT).
        signing_key: MAVLink 2 signing key for every link.
        log, progress: as for `upload_mission`.
        on_vehicle: called with each vehicle's result as soon as it is done.
        window: the least seconds the survey listens (None: `claims.HEARTBEAT_WATCH_S`).
        speed_check: after the survey and before anything is sent, every vehicle's speed
            limit is read (`transfer.SPEED_LIMIT_PARAM`, where its dialect has one) and
            `speed_check({vehicle: (parameter, m/s) or None when unread})` judges the whole
            fleet at once; a line refuses the upload (`SpeedLimitError`, nothing sent to any
            vehicle). "planned" (the default): `speeds.fleet_speed_check(missions)`, the check
            of `upload DIR/ --fleet` without --map: a vehicle below the speed its sortie was
            planned at with a battery is refused, any other below its speed warned about
            (`speeds.SpeedLimitWarning`); `fleet_speed_check(missions, map=m)` judges the
            directory on the map at the limits instead, `force=True` warns instead of
            refusing. None skips the check and reads nothing.

    Returns:
        The report; `report.ok` only if every vehicle holds its mission, read back identical.

    Raises:
        FleetSetupError: `connect` or `system_ids` do not fit the missions (nothing sent).
        FleetSurveyError: the vehicles heard do not match the missions (nothing sent).
        SpeedLimitError: `speed_check` refused a vehicle's speed limit (nothing sent).
        DuplicateVehicleError: one system id claimed from two addresses (nothing sent, or the
            vehicles before it only).
        ValueError: bad arguments or items MAVLink cannot carry (before anything is sent).
    """
    from lamde_mission.items import MISSION_TYPE
    from lamde_mission.vehicle.upload import VIAS, upload_mission
    from lamde_mission.vehicle.wire import wire_mission

    if not any(fm.mission for fm in missions):
        raise ValueError("no missions to upload")
    if via not in VIAS:
        raise ValueError(f"via must be one of {', '.join(VIAS)}, got {via!r}")
    for k, fm in enumerate(missions):
        if fm.vehicle != k + 1:
            raise ValueError(f"missions[{k}] is for vehicle {fm.vehicle}, expected {k + 1}")
        if fm.mission:
            wire_mission(fm.mission, MISSION_TYPE.MISSION)
        if fm.fence:
            wire_mission(fm.fence, MISSION_TYPE.FENCE)
        if fm.rally:
            wire_mission(fm.rally, MISSION_TYPE.RALLY)
    parse_connections(list(connect))
    if speed_check == "planned":
        from lamde_mission.vehicle.speeds import fleet_speed_check

        speed_check = fleet_speed_check(missions)
    elif isinstance(speed_check, str):
        raise ValueError(f'speed_check must be a function, "planned" or None, got '
                         f"{speed_check!r}")
    t0 = time.monotonic()
    conns, ids, listened = assign_system_ids(
        len(missions), list(connect), system_ids, timeout=timeout, window=window,
        signing_key=signing_key,
    )  # fmt: skip
    limits: dict[int, tuple[str, float] | None] = {}
    if speed_check is not None:
        limits = _read_speed_limits(missions, conns, ids, via=via, timeout=timeout,
                                    autopilot=autopilot, signing_key=signing_key, log=log)
        problem = speed_check(limits)
        if problem is not None:
            raise SpeedLimitError(problem)
    report = FleetReport(survey_s=listened)
    for fm, conn, sid in zip(missions, conns, ids, strict=True):
        result = VehicleResult(fm.vehicle, sid, conn, fm.source, skipped=not fm.mission)
        if result.skipped:
            report.results.append(result)
            if on_vehicle is not None:
                on_vehicle(result)
            continue
        try:
            result.report = upload_mission(
                fm.mission, fm.fence, connect=conn, via=via, timeout=timeout, attempts=attempts,
                log=log, progress=progress, rally=fm.rally, autopilot=autopilot,
                signing_key=signing_key, heartbeat_watch=0.0, system_id=sid,
                speed_check=None,  # every limit was read and judged above, the fleet at once
            )  # fmt: skip
            result.report.speed_limit = limits.get(fm.vehicle)
        except DuplicateVehicleError as exc:
            exc.fleet_report = report  # the vehicles done before it
            raise
        except VehicleError as exc:
            result.error = exc
        report.results.append(result)
        if on_vehicle is not None:
            on_vehicle(result)
    report.total_s = time.monotonic() - t0
    return report

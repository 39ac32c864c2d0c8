"""Upload, read back, compare, retry: the part both uploaders share.

A client (`MavsdkClient` in `upload.py`, `MavlinkClient` in `mavlink_client.py`) knows how to
connect, upload, download and clear one list of one mission type. `upload_and_verify` runs the
whole transfer on it: mission up, fence up (or cleared), both down, compared item by item, and
the whole transfer again (up to `attempts` times) when a step times out or the read-back
differs. Lost messages are recovered inside each step (per-item re-requests and resends, the
mission protocol's own recovery); a step times out after `timeout` s without progress.
The read-back is what decides: an upload whose final MISSION_ACK was lost (MAVSDK reports a
timeout) still counts when the vehicle hands back exactly what was sent.

A refusal by the vehicle (MISSION_ACK with an error code, other than a generic error) is not
retried: the vehicle would refuse again.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Protocol

from pymavlink.dialects.v20 import common as mavlink2

from lamde_mission.items import CMD, FRAME, MISSION_TYPE, MissionItem
from lamde_mission.storage import Dialect, dialect_for_autopilot, dialect_of
from lamde_mission.vehicle.wire import (
    Difference,
    WireItem,
    compare_items,
    from_wire,
    mission_type_name,
    wire_mission,
)
from planner_core.textio import counted, for_count

__all__ = [
    "VehicleError",
    "NoVehicleError",
    "TransferError",
    "MissionRejectedError",
    "ReadbackMismatchError",
    "VehicleInfo",
    "MissionClient",
    "UploadReport",
    "upload_and_verify",
    "DuplicateVehicleError",
    "no_vehicle_message",
    "autopilot_name",
    "vehicle_type_name",
]


class VehicleError(Exception):
    """A transfer to or from a vehicle failed (the CLI prints it and exits with status 1)."""

    report: UploadReport | None = None


class NoVehicleError(VehicleError):
    """Nothing answered at the address within the timeout."""


class SpeedLimitError(VehicleError):
    """The vehicle's speed limit (`SPEED_LIMIT_PARAM`) makes the mission fail a check: refused
    after connecting, before anything was sent."""


#: per storage dialect, the vehicle parameter that caps a mission's horizontal speed: PX4's
#: multicopter FlightTaskAuto flies a DO_CHANGE_SPEED's cruise speed at most at MPC_XY_VEL_MAX
#: (m/s; 12 by default). ArduPilot Copter's WPNAV_SPEED is the speed a mission starts at, which
#: DO_CHANGE_SPEED replaces: no cap is read there.
SPEED_LIMIT_PARAM: dict[str, str] = {"px4": "MPC_XY_VEL_MAX"}


def speed_limit_param(asked: Dialect, heard: Dialect) -> str | None:
    """The speed limit parameter to read from a vehicle: the asked dialect's
    (`SPEED_LIMIT_PARAM`), unless the vehicle's HEARTBEAT names another autopilot (an
    ArduPilot vehicle uploaded with --autopilot px4 has no MPC_XY_VEL_MAX: asking would only
    wait out `PARAM_TIMEOUT_S`); a generic HEARTBEAT names none.

    Args:
        asked: the dialect the mission is stored in (--autopilot, or the HEARTBEAT's).
        heard: the dialect of the HEARTBEAT's autopilot field (`dialect_for_autopilot`).

    Returns:
        The parameter's name, or None.
    """
    if heard.name != "generic" and heard.name != asked.name:
        return None
    return SPEED_LIMIT_PARAM.get(asked.name)
#: s to wait for the vehicle's answer to the parameter read
PARAM_TIMEOUT_S = 3.0


def no_vehicle_message(
    endpoint: object, timeout: float, system_id: int | None, heard: Sequence[int],
    bad_signatures: int = 0,
) -> str:
    """The line of a NoVehicleError: nothing heard, or not the system asked for.

    Args:
        endpoint: the connection (printed).
        timeout: how long it listened (s).
        system_id: the system id asked for (None: any vehicle).
        heard: the system ids of the vehicles that were heard.
        bad_signatures: messages dropped on a signed link for a missing or wrong signature
            (then the key, not the link, is the likely fault, and the line says so).

    Returns:
        One line naming the connection, the wait and, for a system id, what answered instead.
    """
    key = (f"; {counted(bad_signatures, 'message')} came unsigned or signed with another key: "
           "check --signing-key against the vehicle's" if bad_signatures else "")  # fmt: skip
    if system_id is None:
        return f"no vehicle heard at {endpoint} within {timeout:g} s{key}"
    systems = ", ".join(str(s) for s in heard)
    others = (f"heard only {for_count(len(heard), 'system')} {systems}" if heard
              else "no vehicle heard at all")  # fmt: skip
    wait = f"heard at {endpoint} within {timeout:g} s"
    return f"no vehicle with system id {system_id} {wait} ({others}){key}"


class DuplicateVehicleError(VehicleError):
    """A second autopilot claims the pinned vehicle's system and component ids from another
    address: a second vehicle with the same MAV_SYS_ID, or someone playing the vehicle. Not
    retried: the link cannot tell which is the vehicle."""


class TransferError(VehicleError):
    """A transfer step timed out or broke off (lost messages, vehicle gone); worth a retry.

    Args:
        message: the one line the CLI prints.
        unanswered: the vehicle answered nothing of this list's upload (no item requested, no
            MISSION_ACK): no item reached it, so nothing was stored and no read-back can
            settle the list (`upload_and_verify` ends the attempt at once). False where the
            client cannot tell (MAVSDK's TIMEOUT) or the vehicle did answer (the final ACK may
            be what was lost: the list's read-back decides).
    """

    def __init__(self, message: str, *, unanswered: bool = False) -> None:
        super().__init__(message)
        self.unanswered = unanswered


class MissionRejectedError(VehicleError):
    """The vehicle refused a list: `name` is its MISSION_ACK code (or MAVSDK's result) by name."""

    def __init__(
        self,
        message: str,
        *,
        name: str,
        code: int | None = None,
        mission_type: int = MISSION_TYPE.MISSION,
        retryable: bool = False,
    ) -> None:
        super().__init__(message)
        self.name = name
        self.code = code
        self.mission_type = mission_type
        self.retryable = retryable


class ReadbackMismatchError(VehicleError):
    """The lists read back differ from what was sent; `differences` says where."""

    def __init__(self, differences: Sequence[Difference]) -> None:
        self.differences = list(differences)
        shown = "; ".join(str(d) for d in self.differences[:5])
        more = len(self.differences) - 5
        tail = f" (+{more} more)" if more > 0 else ""
        super().__init__(f"read-back differs from what was sent: {shown}{tail}")


#: MISSION_ACK codes that mean "try again" rather than "no"
RETRYABLE_ACKS = frozenset({mavlink2.MAV_MISSION_ERROR, mavlink2.MAV_MISSION_OPERATION_CANCELLED})


#: the autopilots by the names their makers use (MAV_AUTOPILOT number -> name); any other
#: MAV_AUTOPILOT is named by MAVLink's enum without "MAV_AUTOPILOT_" (`autopilot_name`)
AUTOPILOT_NAMES: dict[int, str] = {
    mavlink2.MAV_AUTOPILOT_PX4: "PX4",
    mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA: "ArduPilot",
    mavlink2.MAV_AUTOPILOT_GENERIC: "generic",
}


def autopilot_name(autopilot: int) -> str | None:
    """The autopilot of a HEARTBEAT in the words both uploaders print.

    Args:
        autopilot: the HEARTBEAT's MAV_AUTOPILOT number.

    Returns:
        "PX4", "ArduPilot" (MAV_AUTOPILOT_ARDUPILOTMEGA) or "generic" (`AUTOPILOT_NAMES`);
        another MAVLink autopilot by its enum name without "MAV_AUTOPILOT_" (e.g.
        "SLUGS"); None for MAV_AUTOPILOT_INVALID (not an autopilot) and numbers MAVLink
        lacks. `storage.dialect_for_autopilot` reads every one of these.
    """
    a = int(autopilot)
    if a in AUTOPILOT_NAMES:
        return AUTOPILOT_NAMES[a]
    entry = mavlink2.enums["MAV_AUTOPILOT"].get(a)
    if entry is None or a == mavlink2.MAV_AUTOPILOT_INVALID:
        return None
    return entry.name.removeprefix("MAV_AUTOPILOT_")


def vehicle_type_name(mav_type: int) -> str | None:
    """The vehicle type of a HEARTBEAT in the words both uploaders print: MAVLink's MAV_TYPE
    name, lower case, without "MAV_TYPE_", words apart ("quadrotor", "hexarotor", "fixed
    wing", "vtol tiltrotor", "ground rover").

    Args:
        mav_type: the HEARTBEAT's MAV_TYPE number.

    Returns:
        The name, or None for numbers MAVLink lacks.
    """
    entry = mavlink2.enums["MAV_TYPE"].get(int(mav_type))
    if entry is None or entry.name.endswith("_ENUM_END"):
        return None
    return entry.name.removeprefix("MAV_TYPE_").lower().replace("_", " ")


@dataclass(frozen=True)
class VehicleInfo:
    """Who answered: MAVLink system/component ids, autopilot and vehicle type, named from the
    vehicle's HEARTBEAT by both uploaders alike (`autopilot_name`, `vehicle_type_name`)."""

    system_id: int
    component_id: int = 1
    autopilot: str | None = None  # "PX4", "ArduPilot", "generic", ... (`autopilot_name`)
    vehicle_type: str | None = None  # "quadrotor", "fixed wing", ... (`vehicle_type_name`)
    signed: bool = False  # its HEARTBEAT carried a MAVLink 2 signature

    @classmethod
    def from_heartbeat(cls, msg: object) -> VehicleInfo:
        """From a pymavlink HEARTBEAT message (both uploaders: the MAVSDK client takes the
        one its relay pinned the vehicle by).

        Args:
            msg: the HEARTBEAT (its source system and component, autopilot, type).

        Returns:
            The `VehicleInfo`: autopilot by `autopilot_name`, vehicle type by
            `vehicle_type_name`, `signed` when the message carried a MAVLink 2 signature.
        """
        from lamde_mission.vehicle.signing import carries_signature

        return cls(
            system_id=int(msg.get_srcSystem()), component_id=int(msg.get_srcComponent()),
            autopilot=autopilot_name(msg.autopilot), vehicle_type=vehicle_type_name(msg.type),
            signed=carries_signature(msg),
        )  # fmt: skip

    def describe(self) -> str:
        """The vehicle in a few words, for the report.

        Returns:
            "system N" then the autopilot and vehicle type where known, comma-separated.
        """
        parts = [f"system {self.system_id}"]
        parts += [p for p in (self.autopilot, self.vehicle_type) if p]
        return ", ".join(parts)


class MissionClient(Protocol):
    """What `upload_and_verify` needs from an uploader; every call gives up (TransferError)
    after `timeout` s without progress."""

    name: str

    def connect(self, timeout: float) -> VehicleInfo:
        """Wait for the vehicle's HEARTBEAT.

        Args:
            timeout: seconds to wait.

        Returns:
            Who answered.

        Raises:
            NoVehicleError: nothing answered within `timeout`.
        """
        ...

    def read_param(self, name: str, timeout: float) -> float | None:
        """One parameter of the vehicle (the MAVLink parameter protocol), by name.

        Args:
            name: the parameter's id (at most 16 characters).
            timeout: seconds to wait.

        Returns:
            Its value, or None when the vehicle does not answer in time.
        """
        ...

    def upload(self, items: Sequence[WireItem], mission_type: int, timeout: float) -> None:
        """Upload one list.

        Args:
            items: the list, seq 0..n-1 (`wire_mission`).
            mission_type: its MAV_MISSION_TYPE.
            timeout: seconds without progress before giving up.

        Raises:
            TransferError: no progress within `timeout`.
            MissionRejectedError: the vehicle refused the list.
        """
        ...

    def download(self, mission_type: int, timeout: float) -> list[WireItem]:
        """Read one list back.

        Args:
            mission_type: its MAV_MISSION_TYPE.
            timeout: seconds without progress before giving up.

        Returns:
            The items the vehicle holds, in seq order.

        Raises:
            TransferError: no progress within `timeout`.
        """
        ...

    def clear(self, mission_type: int, timeout: float) -> None:
        """Clear one list on the vehicle.

        Args:
            mission_type: its MAV_MISSION_TYPE.
            timeout: seconds without progress before giving up.

        Raises:
            TransferError: no progress within `timeout`.
            MissionRejectedError: the vehicle refused.
        """
        ...

    def close(self) -> None: ...


@dataclass
class UploadReport:
    """What happened: timings in seconds, attempts used, notes and read-back differences."""

    via: str
    endpoint: str
    mission_items: int
    fence_items: int | None  # None: the fence was left as it was (no fence in the file)
    vehicle: VehicleInfo | None = None
    ok: bool = False
    connect_s: float | None = None
    upload_s: float | None = None
    verify_s: float | None = None
    total_s: float | None = None
    attempts: int = 0
    max_attempts: int = 1
    errors: list[str] = field(default_factory=list)  # one line per failed attempt
    notes: list[str] = field(default_factory=list)
    differences: list[Difference] = field(default_factory=list)
    rally_items: int | None = None  # None: the rally points were left as they were
    dialect: str | None = None  # px4 / ardupilot / generic: the storage rules compared under
    #: the mission as last read back from the vehicle, in the file's numbering (no home item)
    readback: list[MissionItem] = field(default_factory=list)
    #: (parameter, value) of the vehicle's horizontal speed limit (`SPEED_LIMIT_PARAM`), m/s,
    #: when it was read (a `speed_check` given, a dialect that has one, the vehicle answered)
    speed_limit: tuple[str, float] | None = None

    def lines(self, max_differences: int = 20) -> list[str]:
        """The short report `lamde-mission upload` prints.

        Args:
            max_differences: the most read-back differences listed (the rest counted).

        Returns:
            The lines, without newlines.
        """
        out = []
        if self.vehicle is not None and self.connect_s is not None:
            out.append(
                f"connected to {self.vehicle.describe()} at {self.endpoint} via {self.via} "
                f"in {self.connect_s:.2f} s"
            )
        if self.fence_items is None:
            fence = "(the fence left as it is: the file has none)"
        elif self.fence_items == 0:
            fence = "and cleared the fence (the file has none)"
        else:
            fence = f"and {counted(self.fence_items, 'fence item')}"
        if self.dialect is not None:
            out.append(f"compared under {self.dialect}'s storage rules"
                       + (" (item 0 is the vehicle's home position)"
                          if self.dialect == "ardupilot" else ""))  # fmt: skip
        if self.speed_limit is not None:
            out.append(f"the vehicle's speed limit: {self.speed_limit[0]} "
                       f"{self.speed_limit[1]:g} m/s")
        for k, err in enumerate(self.errors, start=1):
            out.append(f"attempt {k} of {self.max_attempts} failed: {err}")
        out.extend(f"note: {n}" for n in self.notes)
        if self.ok:
            out.append(
                f"uploaded {counted(self.mission_items, 'mission item')} {fence} in "
                f"{self.upload_s:.2f} s (attempt {self.attempts} of {self.max_attempts})"
            )
            if self.rally_items is None:
                out.append("rally points left as they are (the file has none)")
            else:
                out.append(f"uploaded {counted(self.rally_items, 'rally point')}")
            out.append(f"read back and compared in {self.verify_s:.2f} s: identical")
        elif self.differences:
            out.append(
                f"read-back differs from what was sent "
                f"({counted(len(self.differences), 'difference')}):"
            )
            out.extend(f"  {d}" for d in self.differences[:max_differences])
            if len(self.differences) > max_differences:
                out.append(f"  ... and {len(self.differences) - max_differences} more")
            out.append(
                f"on the vehicle now: the lists read back above ({len(self.readback)} mission "
                "items), NOT the planned mission: do not fly it; upload again or clear it"
            )
        return out


def mission_for_dialect(
    mission: Sequence[MissionItem], dialect: Dialect
) -> tuple[list[MissionItem], list[str]]:
    """The mission list to send to an autopilot of `dialect`, and notes on what changed.

    Whole-second dialects: a LOITER_TIME hover time with a fraction is rounded *up* (the
    vehicle would cut it down, and the sensors would be short of data). ArduPilot: a home
    placeholder goes first as item 0 (the vehicle overwrites it with its home position and
    never flies it) and every DO_JUMP target moves up by one with the items.

    Args:
        mission: the mission items, in the file's numbering.
        dialect: the autopilot's storage rules (`lamde_mission.storage.Dialect`).

    Returns:
        (items, notes): the items renumbered from 0, and one line per change made.
    """
    out: list[MissionItem] = []
    notes: list[str] = []
    for it in mission:
        if (dialect.whole_second_hover and it.command == CMD.LOITER_TIME
                and math.isfinite(it.param1) and it.param1 != math.floor(it.param1)):
            up = float(math.ceil(it.param1))
            notes.append(f"item {it.seq}: hover time {it.param1:g} s rounded up to {up:g} s "
                         f"({dialect.name} keeps whole seconds)")  # fmt: skip
            it = replace(it, param1=up)
        out.append(it)
    if dialect.home_item:
        first = next((it for it in out if it.frame != FRAME.MISSION
                      and not (it.x == 0 and it.y == 0)), None)  # fmt: skip
        home = MissionItem(seq=0, command=CMD.WAYPOINT, frame=FRAME.GLOBAL,
                           x=first.x if first else 0.0, y=first.y if first else 0.0, z=0.0)
        out = [home] + [replace(it, param1=it.param1 + 1) if it.command == CMD.DO_JUMP else it
                        for it in out]  # fmt: skip
        notes.append("item 0 is a home placeholder (ArduPilot keeps its home there); the "
                     "mission follows as items 1..n, DO_JUMP targets moved with them")
    return [it.with_seq(k) for k, it in enumerate(out)], notes


def mission_from_dialect(items: Sequence[MissionItem], home_item: bool) -> list[MissionItem]:
    """A read-back in the file's numbering: without the home item, DO_JUMP targets back.

    Args:
        items: the items read back.
        home_item: whether item 0 is the vehicle's home (`Dialect.home_item`).

    Returns:
        The items renumbered from 0 without item 0 and DO_JUMP targets down by one; a copy
        of `items` when `home_item` is False.
    """
    if not home_item:
        return list(items)
    out = [replace(it, param1=it.param1 - 1) if it.command == CMD.DO_JUMP else it
           for it in items[1:]]  # fmt: skip
    return [it.with_seq(k) for k, it in enumerate(out)]


def check_mission_list(mission: Sequence[MissionItem]) -> None:
    """ValueError for fence or rally commands in a mission list (they would replace the
    vehicle's mission with fence vertices).

    Args:
        mission: the mission list.

    Raises:
        ValueError: the first fence or rally command, naming its item.
    """
    for it in mission:
        if it.command in CMD.FENCE_COMMANDS or it.command == CMD.RALLY_POINT:
            raise ValueError(f"mission item {it.seq}: command {it.command} is a fence/rally "
                             "item, not a mission item; send it in the fence or rally list")


def upload_and_verify(
    client: MissionClient,
    mission: Sequence[MissionItem],
    fence: Sequence[MissionItem] | None = (),
    *,
    rally: Sequence[MissionItem] | None = None,
    autopilot: str | None = None,
    timeout: float = 30.0,
    attempts: int = 3,
    endpoint: str = "",
    log: Callable[[str], None] | None = None,
    speed_check: Callable[[str, float], str | None] | None = None,
) -> UploadReport:
    """Upload `mission` and `fence` through `client`, read both back and compare them.

    `fence=None` leaves the vehicle's fence alone; an empty fence clears it; `rally=None` leaves
    the rally points alone. The storage rules (`autopilot`: px4, ardupilot, generic) come from
    the vehicle's HEARTBEAT unless given: for ArduPilot a home placeholder goes first and DO_JUMP
    targets move with the items (`mission_for_dialect`), and the read-back is compared under
    those rules (item 0, the vehicle's home, is not compared); `report.readback` holds it in
    the file's numbering. Connecting may take up to `timeout` s; each list's transfer gives up
    after `timeout` s without progress (the clients recover lost messages one by one, as the
    mission protocol specifies), and the whole transfer is tried again up to `attempts` times.

    Args:
        client: the uploader (`MissionClient`).
        mission: the mission items, in the file's numbering.
        fence: the fence items; None leaves the vehicle's fence alone, empty clears it.
        rally: the rally items; None leaves the vehicle's rally points alone.
        autopilot: "px4", "ardupilot" or "generic"; None: from the vehicle's HEARTBEAT.
        timeout: seconds to connect, and per list without progress.
        attempts: how many times the whole transfer is tried, >= 1.
        endpoint: the connection, for the report.
        log: called with a line per step (None: silent).
        speed_check: where the dialect has a speed limit parameter (`SPEED_LIMIT_PARAM`),
            it is read after connecting (`report.speed_limit`; a note when the vehicle does
            not answer in `PARAM_TIMEOUT_S`) and `speed_check(name, value m/s)` says what
            the mission fails at that speed, or None; None: nothing is read.

    Returns:
        The report, on success (`ok` True).

    Raises:
        VehicleError: NoVehicleError, MissionRejectedError, TransferError or
            ReadbackMismatchError (each with `.report`) on failure; SpeedLimitError (with
            `.report`; nothing sent) with `speed_check`'s line.
        ValueError: items MAVLink cannot carry, an empty mission, fence or rally commands in
            the mission, `attempts` < 1, `timeout` <= 0 or an unknown `autopilot`.
    """
    if attempts < 1:
        raise ValueError(f"attempts must be >= 1, got {attempts}")
    if timeout <= 0:
        raise ValueError(f"timeout must be > 0, got {timeout}")
    if not mission:
        raise ValueError("the mission is empty")
    check_mission_list(mission)
    wire_mission(mission, MISSION_TYPE.MISSION)  # what MAVLink cannot carry: before connecting
    up_fence = None if fence is None else wire_mission(fence, MISSION_TYPE.FENCE)
    up_rally = None if rally is None else wire_mission(rally, MISSION_TYPE.RALLY)
    report = UploadReport(
        via=client.name, endpoint=endpoint, mission_items=len(mission),
        fence_items=None if up_fence is None else len(up_fence), max_attempts=attempts,
    )  # fmt: skip
    say = log or (lambda _s: None)
    t_start = time.monotonic()
    try:
        t0 = time.monotonic()
        report.vehicle = client.connect(timeout)
        heard = dialect_for_autopilot(report.vehicle.autopilot)
        dialect = dialect_of(autopilot) if autopilot is not None else heard
        report.dialect = dialect.name
        # the HEARTBEAT names another autopilot than the one asked for (generic says nothing)
        other = heard.name != "generic" and heard.name != dialect.name
        if other:
            report.notes.append(f"--autopilot {dialect.name}, but the vehicle's HEARTBEAT says "
                                f"{heard.name}: the mission is stored and compared as "
                                f"{dialect.name} asks")  # fmt: skip
        sent, notes = mission_for_dialect(mission, dialect)
        report.notes.extend(notes)
        up_mission = wire_mission(sent, MISSION_TYPE.MISSION)
        report.mission_items = len(up_mission)
        report.rally_items = None if up_rally is None else len(up_rally)
        report.connect_s = time.monotonic() - t0
        say(f"connected to {report.vehicle.describe()} in {report.connect_s:.2f} s")
        param = speed_limit_param(dialect, heard)
        if speed_check is not None and other and SPEED_LIMIT_PARAM.get(dialect.name):
            report.notes.append(f"{SPEED_LIMIT_PARAM[dialect.name]} is {dialect.name}'s and the "
                                f"vehicle says it is {heard.name}: its speed limit is not "
                                "read")  # fmt: skip
        elif speed_check is not None and param is not None:
            value = client.read_param(param, min(timeout, PARAM_TIMEOUT_S))
            if value is None:
                report.notes.append(f"the vehicle did not say its {param} in "
                                    f"{min(timeout, PARAM_TIMEOUT_S):g} s: the mission's speed "
                                    "is not checked against its limit")  # fmt: skip
            else:
                report.speed_limit = (param, float(value))
                say(f"the vehicle's {param} is {value:g} m/s")
                problem = speed_check(param, float(value))
                if problem is not None:
                    raise SpeedLimitError(problem)
        last: VehicleError | None = None
        for attempt in range(1, attempts + 1):
            report.attempts = attempt
            report.differences = []
            try:
                _attempt(client, up_mission, up_fence, up_rally, timeout, report, say,
                         home_item=dialect.home_item)  # fmt: skip
                report.ok = True
                return report
            except MissionRejectedError as exc:
                if not exc.retryable:
                    raise
                last = exc
            except (TransferError, ReadbackMismatchError) as exc:
                last = exc
            if attempt < attempts:
                report.errors.append(str(last))
                say(f"attempt {attempt} of {attempts} failed: {last}")
        assert last is not None
        raise last
    except VehicleError as exc:
        exc.report = report
        raise
    finally:
        report.total_s = time.monotonic() - t_start


def _attempt(
    client: MissionClient,
    mission: list[WireItem],
    fence: list[WireItem] | None,
    rally: list[WireItem] | None,
    timeout: float,
    report: UploadReport,
    say: Callable[[str], None],
    *,
    home_item: bool = False,
) -> None:
    """One whole attempt: each list up (or cleared), then each read back and compared.

    A list whose upload was not confirmed (TransferError: the final ACK may be what was lost)
    is read back at once, before the next list goes up: a vehicle that stopped answering fails
    the attempt after one more wait instead of one per list. A list the vehicle never answered
    at all (`TransferError.unanswered`) fails the attempt with no read-back; a read-back that
    fails after an unconfirmed upload fails it with a line naming both steps.

    Each client call is allowed `timeout` s without progress; the client's per-message
    timeouts and re-requests do the recovery (`MissionClient`), and its TransferError names
    the list and the step ("mission upload: no answer from the vehicle while waiting ...").
    """
    unconfirmed: list[str] = []
    diffs: list[Difference] = []
    read: set[int] = set()
    upload_s = verify_s = 0.0
    lists = [(MISSION_TYPE.MISSION, mission)]
    if fence is not None:
        lists.append((MISSION_TYPE.FENCE, fence))
    if rally is not None:
        lists.append((MISSION_TYPE.RALLY, rally))

    def read_back(t: int, items: list[WireItem]) -> list[Difference]:
        got = client.download(t, timeout)
        found = compare_items(items, got, mission_type_name(t))
        if t == MISSION_TYPE.MISSION:
            if home_item:  # the vehicle writes its home position into item 0
                found = [d for d in found if d.index != 0]
            report.readback = mission_from_dialect([from_wire(w) for w in got], home_item)
        read.add(t)
        return found

    for t, items in lists:
        t0 = time.monotonic()
        try:
            if items:
                client.upload(items, t, timeout)
            else:
                client.clear(t, timeout)
        except TransferError as exc:
            upload_s += time.monotonic() - t0
            if exc.unanswered:
                raise
            # the final ACK may be what was lost: this list's read-back decides, now
            say(f"{exc}; the read-back decides")
            t0 = time.monotonic()
            try:
                found = read_back(t, items)
            except TransferError as again:  # the line names both steps, the upload first
                raise TransferError(f"{exc}; the read-back failed too: {again}") from None
            verify_s += time.monotonic() - t0
            if found:
                report.differences = diffs + found
                raise TransferError(f"{exc}; the read-back differs ({found[0]})") from None
            unconfirmed.append(str(exc))
            continue
        upload_s += time.monotonic() - t0
    report.upload_s = upload_s
    t0 = time.monotonic()
    for t, items in lists:
        if t not in read:
            diffs += read_back(t, items)
    report.verify_s = verify_s + time.monotonic() - t0
    report.differences = diffs
    if diffs:
        raise ReadbackMismatchError(diffs)
    report.notes.extend(f"{u}, but the read-back matches" for u in unconfirmed)

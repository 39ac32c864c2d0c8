"""`lamde-mission upload MISSION`: upload mission + geofence, read them back, compare."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `lamde-mission upload` (options, help).

    Args:
        sub: the subcommands of `lamde_mission.cli.build_parser`.

    Returns:
        The command's parser (`build_parser` sets `run` as its `_run`).
    """
    p = sub.add_parser(
        "upload",
        help="upload a .plan/.waypoints mission to a vehicle and verify it by reading it back",
        description="Upload the mission and the geofence of a QGroundControl .plan (or the "
        "mission of a .waypoints file; the vehicle's fence is then left alone) to a vehicle over "
        "MAVLink, download both back and compare them item by item. Exit status, single file "
        "and --fleet alike: 0 only when every upload is read back identical; 1 when a check "
        "or the link fails: the simulator rejects the mission on --map (nothing sent), no "
        "vehicle answers (with --fleet: a vehicle missing, or more or fewer answering than "
        "fleet.json plans; nothing sent), two autopilots claim the vehicle's system id from "
        "two addresses, a link cannot be opened, the vehicle refuses the mission, a transfer "
        "fails or the read-back differs; 2 for bad input, found before any link is opened: a "
        "bad file, directory or option, or a mission the simulator cannot fly at all (as "
        "verify's exit status 2). Items go up numbered from 0; "
        "a .waypoints file's home line is not uploaded (the mission starts with its first "
        "item, as from a .plan). Every mission first passes the simulator's checks that need "
        "no map (what verify refuses for the mission itself: a negative hover time, a second "
        "take-off, a frame or command the simulator cannot fly, an altitude beyond 10 km of "
        "home), exit status 2 unless --force. Try it with `lamde-mission mock-vehicle` running "
        "in another terminal. With --fleet, MISSION is a sortie directory (`lamde-mission plan "
        "MAP -o DIR/` for a map with a fleet or a battery: DIR/fleet.json and "
        "DIR/mission-v{k}-s{j}.plan) and vehicle k gets its first sortie, mission-v{k}-s1.plan: "
        "the vehicles are addressed by MAVLink system id on one connection (--sysid, or the "
        "system ids heard there in ascending order) or one --connect each; all are heard "
        "before anything is sent (a vehicle missing or a count differing from fleet.json: "
        "exit status 1), then each is uploaded, read back and compared in turn; with --map the "
        "whole directory is first judged as `verify MAP DIR/` judges it (docs/fleet.md). "
        "Before sending, each PX4 vehicle's MPC_XY_VEL_MAX is read: below the speed a mission "
        "asks, --map judges it again at that limit; without --map a sortie planned with a "
        "battery is refused (exit status 1, nothing sent to any vehicle: its energy at the "
        "limit is unchecked; --force sends it), anything else gets a warning (docs/flying.md).",
    )
    p.add_argument("mission", help="mission file (.plan or .waypoints); with --fleet a sortie "
                   "directory")
    p.add_argument(
        "--connect",
        default="udpin://0.0.0.0:14540",
        metavar="URL",
        help="udpin://HOST:PORT listens for the vehicle on UDP, udpout://HOST:PORT sends to "
        "it, tcpout://HOST:PORT connects to its TCP server, tcpin://HOST:PORT waits for a TCP "
        "connection, serial:///dev/DEVICE:BAUD opens a serial port; the same for both "
        "uploaders (default: %(default)s, QGroundControl's convention for a radio link). "
        "0.0.0.0 listens on every network interface: anyone on those networks can send the "
        "first HEARTBEAT and be taken for the vehicle, or read the mission (MAVLink without "
        "signing has no authentication). Both uploaders listen to HEARTBEATs for 1.2 s before "
        "sending anything and stop (exit status 1, both addresses named) when a second "
        "address claims the vehicle's system and component id, then or later. On a shared "
        "LAN listen on the radio's address or 127.0.0.1, send to the vehicle's own address "
        "with udpout://, or sign the link (--signing-key)",
    )
    p.add_argument(
        "--via",
        choices=("mavsdk", "pymavlink"),
        default="mavsdk",
        help="uploader: MAVSDK's MissionRaw or our pymavlink client (default: %(default)s)",
    )
    p.add_argument(
        "--timeout",
        type=float,
        default=30.0,
        metavar="S",
        help="seconds to wait for the vehicle, and without progress in a transfer before the "
        "attempt is given up (lost items are re-requested one by one; default: 30)",
    )
    p.add_argument(
        "--attempts",
        type=int,
        default=3,
        metavar="N",
        help="retry a failed transfer as a whole up to N times in all (default: 3)",
    )
    p.add_argument(
        "--autopilot",
        choices=("px4", "ardupilot", "generic"),
        help="storage rules to upload and compare under (default: from the vehicle's "
        "HEARTBEAT autopilot field). ardupilot: item 0 is a home placeholder, DO_JUMP targets "
        "move with the items, hover times are whole seconds (rounded up)",
    )
    p.add_argument(
        "--map",
        metavar="MAP",
        help="replay the mission on MAP in the simulator before sending, as `verify MAP "
        "MISSION` does: when a check fails (C1..C5, CLEAR, MARGIN, ENDS, ALT, ENERGY) nothing "
        "is sent, exit status 1, unless --force; a mission the simulator cannot fly at all (a "
        "second take-off, an unusable hover time) is bad input, exit status 2 unless --force. "
        "With --fleet the whole sortie directory is replayed and judged first, exactly as "
        "`verify MAP DIR/` does, with the same exit statuses; a vehicle whose speed limit is "
        "below the mission's speed is judged again at its limit before anything is sent",
    )
    p.add_argument("--origin", metavar="LAT,LON[,ALT]",
                   help="with --map: the WGS84 position of the map's (0, 0) (degrees, degrees, "
                   "metres AMSL), for a map that has no origin")
    p.add_argument(
        "--force",
        action="store_true",
        help="send a mission the simulator rejects, with or without --map, or a sortie planned "
        "with a battery whose energy at the vehicle's lower speed limit is unchecked (no --map), "
        "with a warning (never one whose fields MAVLink cannot carry)",
    )
    p.add_argument(
        "--signing-key",
        metavar="KEY",
        help="sign the link with MAVLink 2 message signing, the vehicle holding the same key: "
        "64 hex digits (the key) or a passphrase (its SHA-256, as MAVProxy and QGroundControl "
        "derive it); the vehicle's unsigned or wrongly signed messages are then ignored. "
        "Both uploaders (MAVSDK, which cannot sign, through a local signing relay). Default: "
        "the environment variable LAMDE_MAVLINK_SIGNING_KEY "
        "(an option is visible to other users of this machine in the process list)",
    )
    p.add_argument("--fleet", action="store_true",
                   help="MISSION is a sortie directory: each vehicle k of its fleet.json gets "
                   "its first sortie, mission-v{k}-s1.plan; --connect may then list one "
                   "connection per vehicle, comma-separated (default: one for all)")
    p.add_argument("--sortie", type=int, default=1, metavar="J",
                   help="with --fleet: send each vehicle its sortie J, mission-v{k}-sJ.plan "
                   "(after J - 1 battery swaps; a vehicle with fewer sorties gets nothing but "
                   "must still answer; default: 1, the first)")
    p.add_argument("--sysid", metavar="ID[,ID...]",
                   help="the vehicles' MAVLink system ids: with --fleet one per vehicle in "
                   "vehicle order (default: the ids heard, ascending, on one connection; the "
                   "one vehicle heard on each connection); without, the vehicle to upload to "
                   "on a link several vehicles share (default: the first heard)")
    p.add_argument("-v", "--verbose", action="store_true",
                   help="print each step, what was ignored (traffic not from the vehicle or not "
                   "addressed to us) and MAVSDK's own log lines")
    return p


#: printed after a MAVSDK transfer that timed out (docs/upload.md has the arithmetic)
MAVSDK_LOSSY_HINT = (
    "hint: MAVSDK gives up a whole list when one item goes unanswered 5 times (a constant "
    "inside MAVSDK); on a lossy link use --via pymavlink, which asks for each item again until "
    "--timeout passes without progress (docs/upload.md)"
)


#: printed after a transfer that failed when the vehicle signs and we were given no key
UNSIGNED_HINT = (
    "hint: the vehicle signs its messages (MAVLink 2 signing), and a vehicle that signs "
    "ignores unsigned ones: give its key with --signing-key (docs/flying.md)"
)


def _failure_hint(exc: Exception, via: str, key: bytes | None) -> str | None:
    """The hint after a failed transfer: the missing signing key when the vehicle signs and
    no key was given, else MAVSDK's lossy-link hint for a MAVSDK transfer, else none."""
    from lamde_mission.vehicle.transfer import TransferError

    if not isinstance(exc, TransferError):
        return None
    vehicle = exc.report.vehicle if exc.report is not None else None
    if key is None and vehicle is not None and vehicle.signed:
        return UNSIGNED_HINT
    return MAVSDK_LOSSY_HINT if via == "mavsdk" else None


def _read(path: str) -> tuple[list, list | None, list | None]:
    """(mission, fence, rally); the fence is None for a .waypoints file (it cannot hold one),
    the rally list None when the file has no rally points (the vehicle's are left alone)."""
    from lamde_mission.errors import UsageError
    from lamde_mission.formats import MissionFileError, read_mission_lists

    try:
        mission, fence, rally = read_mission_lists(path)
    except MissionFileError as exc:
        raise UsageError(str(exc)) from None
    try:
        with open(path, encoding="utf-8-sig") as fh:
            waypoints = fh.read(64).lstrip().startswith("QGC WPL")
    except (OSError, UnicodeDecodeError):  # read_mission just read it
        waypoints = False
    if not mission:
        raise UsageError(f"{path}: the mission holds no items")
    return mission, (None if waypoints else fence), (rally or None)


class _Progress:
    """Items done per list: an updating line on a terminal's stderr, else (with --verbose) a
    line at each quarter."""

    def __init__(self, verbose: bool) -> None:
        self.tty = sys.stderr.isatty()
        self.verbose = verbose
        self.shown: dict[str, int] = {}

    def __call__(self, what: str, done: int, total: int) -> None:
        if self.tty:
            end = "\n" if done >= total else ""
            print(f"\r  {what}: {done}/{total} items", end=end, file=sys.stderr, flush=True)
            return
        if not self.verbose:
            return
        quarter = 4 * done // max(total, 1)
        if self.shown.get(what, -1) < quarter:
            self.shown[what] = quarter
            print(f"  {what}: {done}/{total} items", file=sys.stderr, flush=True)


def _wire_check(path: str, mission: list, fence: list | None, rally: list | None = None) -> None:
    """Every item as MISSION_ITEM_INT will carry it, before a byte is sent: UsageError naming
    the list, item and field (not forceable: the wire cannot carry it)."""
    from lamde_mission.errors import UsageError
    from lamde_mission.items import MISSION_TYPE
    from lamde_mission.vehicle.wire import wire_mission

    for what, items, t in (("mission", mission, MISSION_TYPE.MISSION),
                           ("fence", fence or [], MISSION_TYPE.FENCE),
                           ("rally", rally or [], MISSION_TYPE.RALLY)):  # fmt: skip
        try:
            wire_mission(items, t)
        except ValueError as exc:
            raise UsageError(f"{path}: {what} {exc}") from None


#: where `--signing-key` is read from when the option is not given
SIGNING_KEY_ENV = "LAMDE_MAVLINK_SIGNING_KEY"


def _signing_key(args: argparse.Namespace) -> bytes | None:
    """The signing key of `--signing-key` (else of $LAMDE_MAVLINK_SIGNING_KEY), or None;
    UsageError for an empty key."""
    import os

    from lamde_mission.errors import UsageError
    from lamde_mission.vehicle.signing import signing_key

    text = args.signing_key if args.signing_key is not None else os.environ.get(SIGNING_KEY_ENV)
    if text is None:
        return None
    try:
        return signing_key(text)
    except ValueError as exc:
        raise UsageError(f"--signing-key: {exc}") from None


def _flight_check(path: str, mission: list, *, force: bool) -> None:
    """The simulator's checks that need no map (`sim.mission.check_items`), before every
    upload: what `verify` refuses for the mission itself (a negative LOITER_TIME, a second
    TAKEOFF, a frame the sim cannot fly, an altitude beyond 10 km of home, nothing to fly) is
    refused here with the same line, exit status 2, unless `force` (then a warning).

    Args:
        path: the mission file, for the message.
        mission: its mission items.
        force: warn and go on instead of refusing.

    Raises:
        UsageError: the mission fails a check and `force` is off.
    """
    from lamde_mission.errors import UsageError
    from planner_core.textio import printable
    from sim.mission import MissionError, check_items

    try:
        check_items(mission)
    except MissionError as exc:
        if not force:
            raise UsageError(f"{path}: {exc}") from None
        print(f"warning: {path}: {printable(str(exc))}; sent anyway (--force)", file=sys.stderr)


#: what follows the simulator's "all constraints hold" line of `--map`: it judged the speeds
#: the missions ask, and a vehicle limited below them is judged again once connected
_LIMIT_NEXT = ("a vehicle whose speed limit is lower is judged again at its limit before "
               "anything is sent")


def _sim_check(path: str, map_path: str, mission: list, *, force: bool,
               origin: str | None = None) -> bool:
    """`upload MISSION --map MAP`: replay `mission` on the map and judge it as `verify MAP
    MISSION` does, before anything is sent.

    Args:
        path: the mission file, for the messages.
        map_path: the map file.
        mission: its mission items.
        force: warn and go on when a check fails or the simulator cannot fly it.
        origin: `--origin`, for a map without an origin.

    Returns:
        True to go on (all hold, or `force`); False when a check fails (printed on stderr,
        one line, nothing sent: exit status 1, as `verify`'s).

    Raises:
        UsageError: a bad map or origin, or a mission the simulator cannot fly (verify's
            exit status 2), unless `force` for the latter.
    """
    from lamde_mission.commands._common import load_map_or_fail, with_origin_or_fail
    from lamde_mission.errors import UsageError
    from planner_core.textio import printable
    from sim import replay, verify
    from sim.mission import MissionError

    m = with_origin_or_fail(load_map_or_fail(map_path), origin)
    verdicts: list = []
    try:
        verdicts = list(verify(replay(mission, m), m))
        problems = [f for f in verdicts if not f.passed]
        lines = [printable(f"{v.name} {v.title}: FAIL, margin {v.margin:.4g} {v.unit}; "
                           f"{v.detail}") for v in problems]  # fmt: skip
    except MissionError as exc:  # a mission the sim cannot fly: verify's line, word for word
        if not force:
            raise UsageError(f"{path}: {exc}") from None
        lines = [printable(str(exc))]
    if not lines:
        energy = ", ENERGY" if any(v.name == "ENERGY" for v in verdicts) else ""
        print(f"simulator: all constraints hold on {printable(map_path)} at the mission's own "
              f"speeds (C1..C5, CLEAR, MARGIN, ENDS, ALT{energy}, as verify judges them; "
              f"{_LIMIT_NEXT})", flush=True)  # fmt: skip
        return True
    return _rejected(path, map_path, "; ".join(lines), force=force)


def _rejected(what: str, map_path: str, failed: str, *, force: bool) -> bool:
    """Say that the simulator rejects `what` (a mission file or a sortie directory) on the
    map, one line on stderr: with `force` a warning (it is sent anyway), else the refusal
    (nothing sent; `verify` shows every verdict).

    Args:
        what: the mission file or sortie directory, as the user gave it.
        map_path: the map file.
        failed: the failing verdicts, joined by "; ", already escaped (`printable`).
        force: warn and go on.

    Returns:
        `force`: True to send anyway, False when nothing is sent.
    """
    from planner_core.textio import printable

    if force:
        print(f"warning: {printable(what)}: the simulator rejects it on {printable(map_path)} "
              f"({failed}); sent anyway (--force)", file=sys.stderr)  # fmt: skip
        return True
    print(f"lamde-mission upload: {printable(what)}: the simulator rejects it on "
          f"{printable(map_path)}: {failed}; nothing sent (`lamde-mission verify "
          f"{printable(map_path)} {printable(what)}` shows every verdict; --force sends it "
          "anyway)", file=sys.stderr)  # fmt: skip
    return False


def _mission_speed_check(path: str, mission: list, map_path: str | None, *, force: bool,
                         origin: str | None = None) -> Callable[[str, float], str | None]:
    """`upload MISSION`'s check of the vehicle's speed limit (`transfer.SPEED_LIMIT_PARAM`,
    read after connecting): `vehicle.speeds.mission_speed_check`, the check the Python
    `upload_mission` applies by default, in the CLI's words (`--map`, `--force`), its
    warnings on stderr and its note on stdout. Below the mission's speed: with `--map` the
    simulator's verdicts with every leg flown at the limit; without, a refusal for a sortie of
    a sortie directory planned with a battery (its energy at the limit is unchecked), else a
    warning (no battery known: no energy to check). The map is loaded only then.

    Args:
        path: the mission file.
        mission: its mission items.
        map_path: `--map`, or None.
        force: warn and send instead of refusing.
        origin: `--origin`, for a map without an origin.

    Returns:
        `check(parameter, limit)` for `upload_mission`'s speed_check: None to send, else the
        refusal line. With a map it replays the mission twice, O(legs).

    Raises:
        UsageError: (from `check`) a bad map or origin.
    """
    from lamde_mission.commands._common import load_map_or_fail, with_origin_or_fail
    from lamde_mission.vehicle.speeds import MISSION_CLI_HINTS, mission_speed_check

    def load() -> object:
        return with_origin_or_fail(load_map_or_fail(map_path), origin)

    return mission_speed_check(
        mission, source=path, map=load if map_path is not None else None, map_label=map_path,
        force=force, hints=MISSION_CLI_HINTS,
        warn=lambda line: print(f"warning: {line}", file=sys.stderr),
        note=lambda line: print(f"note: {line}", flush=True),
    )  # fmt: skip


def _fleet_speed_check(directory: str, missions: list, map_path: str | None, *, force: bool,
                       origin: str | None = None
                       ) -> Callable[[dict[int, tuple[str, float] | None]], str | None]:
    """`upload DIR/ --fleet`'s check of the vehicles' speed limits, read from every vehicle
    before anything is sent: `vehicle.speeds.fleet_speed_check`, the check the Python
    `upload_fleet` applies by default, in the CLI's words (`--map MAP`, `--force`), its
    warnings on stderr and its note on stdout; the map is loaded only when a vehicle is
    below its sorties' speed.

    Args:
        directory: the sortie directory.
        missions: the missions being sent (`vehicle.fleet.sortie_missions`).
        map_path: `--map`, or None.
        force: warn and send instead of refusing.
        origin: `--origin`, for a map without an origin.

    Returns:
        `check(limits)` for `upload_fleet`'s speed_check: None to send, else the refusal line.
        Judging with a map replays every sortie, O(sorties x legs); without, O(vehicles).

    Raises:
        UsageError: (from `check`) a bad map or origin.
    """
    from lamde_mission.commands._common import load_map_or_fail, with_origin_or_fail
    from lamde_mission.vehicle.speeds import CLI_HINTS, fleet_speed_check

    def load() -> object:
        return with_origin_or_fail(load_map_or_fail(map_path), origin)

    return fleet_speed_check(
        missions, directory=directory, map=load if map_path is not None else None,
        map_label=map_path, force=force, hints=CLI_HINTS,
        warn=lambda line: print(f"warning: {line}", file=sys.stderr),
        note=lambda line: print(f"note: {line}", flush=True),
    )  # fmt: skip


def _fleet_sim_check(directory: str, map_path: str, *, force: bool,
                     origin: str | None = None) -> bool:
    """`upload DIR/ --fleet --map MAP`: the whole sortie directory replayed and judged on the
    map exactly as `verify MAP DIR/` judges it (every sortie, C4 and MARGIN over all of them,
    CHAIN, UAVS, FILES), before anything is sent.

    Args:
        directory: the sortie directory.
        map_path: the map file.
        force: warn and go on when a check fails.
        origin: `--origin`, for a map without an origin.

    Returns:
        True to go on (all hold, or `force`); False when a check fails (printed, nothing sent).

    Raises:
        UsageError: a bad map, directory, fleet.json field or mission file (one line).
    """
    from lamde_mission.commands._common import load_map_or_fail, with_origin_or_fail
    from lamde_mission.commands.verify import check_sortie_dir
    from planner_core.textio import counted, printable

    m = with_origin_or_fail(load_map_or_fail(map_path), origin)
    check = check_sortie_dir(m, directory)
    if check.passed:
        print(f"simulator: all constraints hold on {printable(map_path)} for the "
              f"{counted(len(check.sorties), 'sortie')} of {printable(directory)} at their "
              f"planned speeds (as `verify MAP DIR/` judges them; {_LIMIT_NEXT})",
              flush=True)  # fmt: skip
        return True
    failed = "; ".join(printable(x) for x in check.failed())
    return _rejected(directory, map_path, failed, force=force)


def _sysids(text: str | None) -> list[int] | None:
    """`--sysid 1,2,3` as ints (1..255); UsageError naming the bad entry."""
    from lamde_mission.errors import UsageError

    if text is None:
        return None
    out = []
    for part in text.split(","):
        part = part.strip()
        if not part.isdigit() or not 1 <= int(part) <= 255:
            raise UsageError(f"--sysid: {part!r} is not a MAVLink system id (1..255)")
        out.append(int(part))
    return out


def _verbose_log(args: argparse.Namespace):
    """The `log` of the uploaders: each step on stderr with --verbose, and MAVSDK's own lines."""

    def log(text: str) -> None:
        if args.verbose:
            from planner_core.textio import printable

            print(f"  {printable(text)}", file=sys.stderr, flush=True)

    if args.verbose:  # MAVSDK's own log lines (routed to Python logging) on stderr
        import logging

        h = logging.StreamHandler(sys.stderr)
        h.setFormatter(logging.Formatter("  mavsdk: %(message)s"))
        lg = logging.getLogger("lamde_mission.vehicle.mavsdk")
        lg.addHandler(h)
        lg.setLevel(logging.DEBUG)
        lg.propagate = False
    return log


def _print_takeoffs(directory: str, sortie: int, map_path: str | None = None,
                    origin: str | None = None) -> None:
    """When each vehicle's sortie `sortie` takes off, as fleet.json gives it (`takeoff_s`, on
    the plan's clock; a directory written before take-off times has only each vehicle's
    `launch_s`, the first sortie's): the vehicles keep apart in the air and no sensor sends
    to two at once only when they take off so (`lamde_mission.launches`). Then where each
    takes off, its own pad: the mission's NAV_TAKEOFF position (what the vehicle is sent),
    paced from its depot where fleet.json gives the depot ("35 m N, 35 m E of 'yard'"), with
    its latitude and longitude (a fleet.json without depots: with `map_path`, the map's
    depots). `verify`'s PLACES holds fleet.json's places to the missions'."""
    from lamde_mission.formats.fleet import read_fleet_dir
    from lamde_mission.geo import latlon_to_enu
    from lamde_mission.sorties import NAV_TAKEOFF, mission_stands
    from planner_core.model.pads import offset_words
    from planner_core.textio import printable

    fleet = read_fleet_dir(directory)
    depots = dict(fleet.depots)
    if map_path is not None and not depots:  # written before fleet.json gave its depots
        depots = _map_depots_latlon(map_path, origin)
    times, pads = [], []
    for v in fleet.vehicles:
        if len(v.sorties) < sortie:
            continue
        s = v.sorties[sortie - 1]
        t = s.takeoff_s
        if t is None and sortie == 1:
            t = v.launch_s
        times.append(f"vehicle {v.vehicle} at +{t:.0f} s" if t is not None
                     else f"vehicle {v.vehicle} at a time fleet.json does not give")
        up = [(lat, lon) for cmd, lat, lon in mission_stands(s.path) if cmd == NAV_TAKEOFF]
        if not up:  # (an unreadable file: the upload itself says what is wrong with it)
            continue
        lat, lon = up[0]
        depot = depots.get(s.depot_start or "")
        if depot is not None:
            dx, dy = latlon_to_enu(lat, lon, (depot[0], depot[1], 0.0))
            words = offset_words(float(dx), float(dy))
            where = (f"'{printable(s.depot_start)}' itself" if words == "the depot itself"
                     else f"{words} of '{printable(s.depot_start)}'")
        else:
            where = f"'{printable(s.depot_start)}'" if s.depot_start else "its take-off"
        pads.append(f"vehicle {v.vehicle} on {where} (lat {lat:.7f}, lon {lon:.7f})")
    if times:
        print(f"take off (sortie {sortie}, s after vehicle 1's first take-off): "
              + ", ".join(times) + "; the vehicles keep apart in the air and no sensor "
              "sends to two at once only when they take off so", flush=True)  # fmt: skip
    if pads:
        print(f"set each vehicle on its own pad (sortie {sortie}): " + ", ".join(pads),
              flush=True)


def _map_depots_latlon(map_path: str, origin: str | None) -> dict[str, tuple[float, float]]:
    """{depot: (lat, lon)} of the map's sortie sites (`Map.sortie_sites`)."""
    from lamde_mission.commands._common import load_map_or_fail, with_origin_or_fail
    from lamde_mission.sorties import depot_positions

    m = with_origin_or_fail(load_map_or_fail(map_path), origin)
    return {n: (p["lat"], p["lon"]) for n, p in depot_positions(m).items()}


def _run_fleet(args: argparse.Namespace, key: bytes | None) -> int:
    """`upload DIR/ --fleet`: every vehicle's first sortie (see `vehicle.fleet`)."""
    from pathlib import Path

    from lamde_mission.errors import UsageError
    from lamde_mission.formats import MissionFileError
    from lamde_mission.formats.fleet import FleetDirError
    from lamde_mission.vehicle.connection import parse_connections
    from lamde_mission.vehicle.fleet import (
        FleetSetupError,
        FleetSurveyError,
        sortie_missions,
        upload_fleet,
    )
    from lamde_mission.vehicle.transfer import VehicleError
    from planner_core.textio import counted, printable

    conns = [c.strip() for c in args.connect.split(",")]
    try:
        parse_connections(conns)
    except ValueError as exc:
        raise UsageError(f"--connect: {exc}") from None
    ids = _sysids(args.sysid)
    if args.sortie < 1:
        raise UsageError(f"--sortie must be 1 or more, got {args.sortie}")
    try:
        missions = sortie_missions(args.mission, args.sortie)
    except (FleetDirError, MissionFileError, ValueError) as exc:
        raise UsageError(str(exc)) from None
    for fm in missions:
        if fm.mission:
            path = str(Path(args.mission) / fm.source)
            _wire_check(path, fm.mission, fm.fence, fm.rally)
            _flight_check(path, fm.mission, force=args.force)
    from lamde_mission.formats.fleet import read_fleet_dir
    from lamde_mission.sorties import shared_spots

    # what upload prints for the crew (take-off times, pads) is fleet.json's: it must agree
    # with itself and with the missions sent (`FleetDir.disagreements`, without a map; with
    # --map, verify's TIMES, PLACES and FIGURES hold it to the replays instead)
    fleet = read_fleet_dir(args.mission)
    off = None if args.map else fleet.disagreement()
    if off is not None:
        if not args.force:
            print(f"lamde-mission upload: {off}; nothing sent (the crew goes by fleet.json: "
                  "upload prints its take-off times and pads; `lamde-mission verify MAP DIR/` "
                  "holds it to the replays; --force sends it anyway)", file=sys.stderr)
            return 1
        print(f"warning: {off}; sent anyway (--force)", file=sys.stderr)
    shared = shared_spots(fleet)
    if shared is not None:
        if not args.force:
            print(f"lamde-mission upload: {printable(args.mission)}: {shared}; nothing sent "
                  "(--force sends it anyway)", file=sys.stderr)  # fmt: skip
            return 1
        print(f"warning: {printable(args.mission)}: {shared}; sent anyway (--force)",
              file=sys.stderr)  # fmt: skip
    if args.map and not _fleet_sim_check(args.mission, args.map, force=args.force,
                                         origin=args.origin):
        return 1
    n = len(missions)
    which = "first sorties" if args.sortie == 1 else f"sortie {args.sortie}"
    print(f"{args.mission}: {counted(n, 'vehicle')}, {which}: "
          + ", ".join(m.source for m in missions), flush=True)  # fmt: skip

    def done(result: object) -> None:  # each vehicle's lines as soon as it is done
        for line in result.lines():  # type: ignore[attr-defined]
            print(line, flush=True)

    try:
        report = upload_fleet(
            missions, connect=conns, system_ids=ids, via=args.via, timeout=args.timeout,
            attempts=args.attempts, autopilot=args.autopilot, signing_key=key,
            log=_verbose_log(args), progress=_Progress(verbose=args.verbose), on_vehicle=done,
            speed_check=_fleet_speed_check(args.mission, missions, args.map, force=args.force,
                                           origin=args.origin),
        )  # fmt: skip
    except FleetSurveyError as exc:  # the link's answer, not the command: as NoVehicleError
        print(f"lamde-mission upload: {printable(args.mission)}: {printable(str(exc))}",
              file=sys.stderr)  # fmt: skip
        return 1
    except (FleetSetupError, ValueError) as exc:  # a --connect or --sysid list that cannot fit
        raise UsageError(f"{args.mission}: {exc}") from None
    except VehicleError as exc:  # a link that cannot be opened, two autopilots on one id
        print(f"lamde-mission upload: {printable(str(exc))}", file=sys.stderr)
        return 1
    print(report.summary())
    if report.ok:
        _print_takeoffs(args.mission, args.sortie, args.map, args.origin)
    if not report.ok:
        bad = [str(r.vehicle) for r in report.results if not r.ok]
        print(f"lamde-mission upload: vehicle {', '.join(bad)} failed (see above)",
              file=sys.stderr)  # fmt: skip
        hints = [_failure_hint(r.error, args.via, key) for r in report.results
                 if r.error is not None]  # fmt: skip
        for hint in dict.fromkeys(h for h in hints if h is not None):
            print(hint, file=sys.stderr)
        return 1
    return 0


def run(args: argparse.Namespace) -> int:
    """`upload MISSION` (or `upload DIR/ --fleet`): check the mission, upload mission, fence
    and rally, read them back and compare; the report's lines on stdout.

    Args:
        args: the parsed options.

    Returns:
        0 every upload verified; 1 a check or the link failed: the simulator's checks on
        --map (nothing sent), no vehicle answering (with --fleet: the vehicles heard not
        matching fleet.json), two autopilots on one system id, a link that cannot be opened,
        a refused mission, a failed transfer or a read-back that differs.

    Raises:
        UsageError: bad input, before any link is opened: a bad option, mission file or
            sortie directory, or a mission the simulator cannot fly at all without --force
            (one line, exit 2).
    """
    from lamde_mission.errors import UsageError
    from lamde_mission.vehicle.transfer import VehicleError
    from lamde_mission.vehicle.upload import MAX_TIMEOUT_S, upload_mission

    if not (math.isfinite(args.timeout) and 0 < args.timeout <= MAX_TIMEOUT_S):
        raise UsageError(f"--timeout must be a number of seconds in (0, {MAX_TIMEOUT_S:g}], "
                         f"got {args.timeout:g}")
    if args.origin is not None and not args.map:
        raise UsageError("--origin: only with --map (it places the map the simulator replays)")
    if args.attempts < 1:
        raise UsageError(f"--attempts must be at least 1, got {args.attempts}")
    from lamde_mission.vehicle.connection import parse_connection

    if args.fleet:
        return _run_fleet(args, _signing_key(args))
    from pathlib import Path

    if Path(args.mission).is_dir():
        raise UsageError(f"{args.mission}: a directory; to send each vehicle its first sortie "
                         "of a sortie directory, add --fleet")  # fmt: skip
    if args.sortie != 1:
        raise UsageError("--sortie: only with --fleet (a sortie directory)")
    ids = _sysids(args.sysid)
    if ids is not None and len(ids) > 1:
        raise UsageError(f"--sysid: {len(ids)} system ids for one mission (several vehicles: "
                         "--fleet with a sortie directory)")  # fmt: skip
    try:
        parse_connection(args.connect)
    except ValueError as exc:
        raise UsageError(f"--connect: {exc}") from None
    key = _signing_key(args)
    mission, fence, rally = _read(args.mission)
    _wire_check(args.mission, mission, fence, rally)
    _flight_check(args.mission, mission, force=args.force)
    if args.map and not _sim_check(args.mission, args.map, mission, force=args.force,
                                   origin=args.origin):
        return 1

    log = _verbose_log(args)
    try:
        report = upload_mission(
            mission,
            fence,
            connect=args.connect,
            via=args.via,
            timeout=args.timeout,
            attempts=args.attempts,
            log=log,
            progress=_Progress(verbose=args.verbose),
            rally=rally,
            autopilot=args.autopilot,
            signing_key=key,
            system_id=None if ids is None else ids[0],
            speed_check=_mission_speed_check(args.mission, mission, args.map,
                                             force=args.force, origin=args.origin),
        )
    except ValueError as exc:  # items MAVLink cannot carry
        raise UsageError(f"{args.mission}: {exc}") from None
    except VehicleError as exc:
        if exc.report is not None:
            for line in exc.report.lines():
                print(line)
        print(f"lamde-mission upload: {exc}", file=sys.stderr)
        hint = _failure_hint(exc, args.via, key)
        if hint is not None:
            print(hint, file=sys.stderr)
        return 1
    for line in report.lines():
        print(line)
    return 0

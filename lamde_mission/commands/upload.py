"""`lamde-mission upload MISSION`: upload mission + geofence, read them back, compare."""

from __future__ import annotations

import argparse
import math
import sys


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "upload",
        help="upload a .plan/.waypoints mission to a vehicle and verify it by reading it back",
        description="Upload the mission and the geofence of a QGroundControl .plan (or the "
        "mission of a .waypoints file; the vehicle's fence is then left alone) to a vehicle over "
        "MAVLink, download both back and compare them item by item. Exit status 0 only when "
        "they match; 1 when no vehicle answers, the vehicle refuses the mission or the "
        "read-back differs; 2 for a bad file or option. Items go up numbered from 0; "
        "a .waypoints file's home line is not uploaded (the mission starts with its first "
        "item, as from a .plan). Try it with `lamde-mission mock-vehicle` running in another "
        "terminal.",
    )
    p.add_argument("mission", help="mission file (.plan or .waypoints)")
    p.add_argument(
        "--connect",
        default="udpin://0.0.0.0:14540",
        metavar="URL",
        help="udpin://HOST:PORT listens for the vehicle, udpout://HOST:PORT sends to "
        "it (default: %(default)s)",
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
        help="seconds to wait for the vehicle, and for each attempt (default: 30)",
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
    p.add_argument("-v", "--verbose", action="store_true", help="print each step")
    return p


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


def run(args: argparse.Namespace) -> int:
    from lamde_mission.errors import UsageError
    from lamde_mission.vehicle.transfer import VehicleError
    from lamde_mission.vehicle.upload import upload_mission
    from lamde_mission.vehicle.wire import parse_endpoint

    if not (math.isfinite(args.timeout) and args.timeout > 0):
        raise UsageError(f"--timeout must be a positive number of seconds, got {args.timeout:g}")
    if args.attempts < 1:
        raise UsageError(f"--attempts must be at least 1, got {args.attempts}")
    if args.via == "pymavlink":
        try:
            parse_endpoint(args.connect)
        except ValueError as exc:
            raise UsageError(f"--connect: {exc} (the pymavlink uploader speaks UDP only)") from None
    mission, fence, rally = _read(args.mission)

    def log(text: str) -> None:
        if args.verbose:
            print(f"  {text}", file=sys.stderr, flush=True)

    try:
        report = upload_mission(
            mission,
            fence,
            connect=args.connect,
            via=args.via,
            timeout=args.timeout,
            attempts=args.attempts,
            log=log,
            rally=rally,
            autopilot=args.autopilot,
        )
    except ValueError as exc:  # items MAVLink cannot carry
        raise UsageError(f"{args.mission}: {exc}") from None
    except VehicleError as exc:
        if exc.report is not None:
            for line in exc.report.lines():
                print(line)
        print(f"lamde-mission upload: {exc}", file=sys.stderr)
        return 1
    for line in report.lines():
        print(line)
    return 0

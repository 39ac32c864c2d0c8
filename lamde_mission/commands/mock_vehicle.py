"""`lamde-mission mock-vehicle`: a mock autopilot to upload to, in the foreground until Ctrl-C."""

from __future__ import annotations

import argparse
import sys
from typing import Any


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `lamde-mission mock-vehicle` (options, help).

    Args:
        sub: the subcommands of `lamde_mission.cli.build_parser`.

    Returns:
        The command's parser (`build_parser` sets `run` as its `_run`).
    """
    p = sub.add_parser(
        "mock-vehicle",
        help="run a mock MAVLink autopilot (no simulator needed) until Ctrl-C",
        description="Run a mock quadrotor autopilot (MAVLink 2 over UDP, system 1, component 1) "
        "that accepts mission, geofence and rally uploads and hands them back on download. "
        "Pair it with `lamde-mission upload`: by default it sends to 127.0.0.1:14540, where "
        "`upload` listens. With --vehicles N (or --sysids) it runs N vehicles, system ids 1..N: "
        "all on the one link of --connect, told apart by system id only (as a multi-vehicle "
        "radio or a MAVLink router delivers them, and as PX4 SITL instances all reach "
        "QGroundControl's port 14550), or with --ports one link each, on --connect's port + 0, "
        "1, ... (PX4 SITL's offboard ports 14540 + i), or one --connect each, comma-separated; "
        "pair it with `lamde-mission upload DIR/ --fleet`.",
    )
    p.add_argument(
        "--connect",
        default="udpout:127.0.0.1:14540",
        metavar="URL",
        help="udpout:HOST:PORT sends to a ground station listening there; "
        "udpin:HOST:PORT listens (default: %(default)s)",
    )
    p.add_argument("--vehicles", type=int, metavar="N",
                   help="run N mock vehicles, system ids 1..N (default: 1, system 1)")
    p.add_argument("--sysids", metavar="ID[,ID...]",
                   help="the vehicles' system ids, comma-separated, distinct, 1..253 (sets the "
                   "number of vehicles; default 1..N)")
    p.add_argument("--ports", action="store_true",
                   help="one link per vehicle: vehicle i on --connect's port + i (default: all "
                   "on the one link, told apart by system id)")
    p.add_argument(
        "--loss",
        type=float,
        default=0.0,
        metavar="P",
        help="drop this fraction of outgoing messages, 0 <= P < 1 (default: 0)",
    )
    p.add_argument(
        "--loss-in",
        type=float,
        default=0.0,
        metavar="P",
        help="drop this fraction of incoming messages, 0 <= P < 1 (default: 0)",
    )
    p.add_argument(
        "--noisy-gcs-hz",
        type=float,
        default=0.0,
        metavar="HZ",
        help="run a second, noisy ground station (system 254) on the link, broadcasting "
        "mission messages HZ times a second (default: 0, none)",
    )
    p.add_argument(
        "--latency-ms",
        type=float,
        default=0.0,
        metavar="MS",
        help="delay outgoing messages by MS milliseconds (default: 0)",
    )
    p.add_argument(
        "--seed",
        type=int,
        default=0,
        help="seed of the message loss (default: 0; the same seed drops the same messages of "
        "the same exchange; with several vehicles vehicle k draws from SEED + k)",
    )
    p.add_argument(
        "--reject",
        default=None,
        metavar="CODE",
        help="refuse every upload with this MAV_MISSION_RESULT (name such as NO_SPACE "
        "or DENIED, or number)",
    )
    p.add_argument(
        "--max-items",
        type=int,
        default=1000,
        metavar="N",
        help="refuse lists longer than N with MAV_MISSION_NO_SPACE (default: 1000)",
    )
    p.add_argument("--autopilot", choices=("px4", "ardupilot"), default="px4",
                   help="behave as PX4 (default) or ArduPilot (HEARTBEAT autopilot id; item 0 "
                   "is home; LOITER_TIME hover seconds kept whole)")
    p.add_argument("--signing-key", metavar="KEY",
                   help="sign with MAVLink 2 message signing and hear only messages signed "
                   "with this key: 64 hex digits or a passphrase (its SHA-256), as for upload")
    p.add_argument("--heartbeat-hz", type=float, default=1.0, metavar="HZ",
                   help="HEARTBEATs per second (default: 1, as PX4 and ArduPilot send them)")
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="answer this parameter with VALUE (repeatable; PARAM_REQUEST_READ / "
                   "_LIST); by default a PX4 mock says MPC_XY_VEL_MAX=12 and an ArduPilot one "
                   "WPNAV_SPEED=1000, their autopilots' defaults")
    p.add_argument("-q", "--quiet", action="store_true", help="do not print transfer events")
    return p


def _params(given: list[str]) -> dict[str, float]:
    """--param NAME=VALUE, each a MAVLink parameter id (1..16 characters) and a finite number;
    UsageError naming the bad one."""
    import math
    import re

    from lamde_mission.errors import UsageError

    out: dict[str, float] = {}
    for text in given:
        name, sep, value = text.partition("=")
        if not sep or not re.fullmatch(r"[A-Za-z0-9_]{1,16}", name):
            raise UsageError(f"--param: {text!r} is not NAME=VALUE with a parameter id of 1-16 "
                             "letters, digits or underscores")  # fmt: skip
        try:
            v = float(value)
        except ValueError:
            v = math.nan
        if not math.isfinite(v) or abs(v) > 3.4e38:
            raise UsageError(f"--param {name}: {value!r} is not a number a MAVLink parameter "
                             "holds (a finite float32)")  # fmt: skip
        out[name] = v
    return out


def _fleet_ids(args: argparse.Namespace) -> list[int] | None:
    """The system ids of --vehicles / --sysids (None: one vehicle, system 1, as always)."""
    from lamde_mission.errors import UsageError
    from lamde_mission.vehicle.mock_fleet import fleet_system_ids

    if args.vehicles is None and args.sysids is None:
        if args.ports or "," in args.connect:
            raise UsageError("--ports and several --connect need --vehicles N or --sysids")
        return None
    ids = None
    if args.sysids is not None:
        ids = []
        for part in args.sysids.split(","):
            if not part.strip().isdigit():
                raise UsageError(f"--sysids: {part.strip()!r} is not a system id (1..253)")
            ids.append(int(part))
    try:
        return fleet_system_ids(args.vehicles, ids)
    except ValueError as exc:
        raise UsageError(f"--vehicles/--sysids: {exc}") from None


def run(args: argparse.Namespace) -> int:
    """`mock-vehicle`: serve one mock autopilot (or a fleet: --vehicles/--sysids) in the
    foreground until Ctrl-C, then print its message counts on stderr.

    Args:
        args: the parsed options.

    Returns:
        0 once stopped by Ctrl-C.

    Raises:
        UsageError: a bad option (signing key, heartbeat rate, fleet ids, --ports), or a
            --connect address that cannot be opened (one line, exit 2).
    """
    from lamde_mission.errors import UsageError
    from lamde_mission.vehicle.mock import MockVehicle

    def event(text: str) -> None:
        print(text, flush=True)

    key = None
    if args.signing_key is not None:
        from lamde_mission.vehicle.signing import signing_key

        try:
            key = signing_key(args.signing_key)
        except ValueError as exc:
            raise UsageError(f"--signing-key: {exc}") from None
    ids = _fleet_ids(args)
    options = dict(
        loss=args.loss, loss_in=args.loss_in, noisy_gcs_hz=args.noisy_gcs_hz,
        latency_ms=args.latency_ms, reject=args.reject, max_items=args.max_items,
        autopilot=args.autopilot, signing_key=key, params=_params(args.param),
    )  # fmt: skip
    if not (0.0 < args.heartbeat_hz <= 100.0):
        raise UsageError(f"--heartbeat-hz must be in (0, 100], got {args.heartbeat_hz:g}")
    if args.heartbeat_hz != 1.0:
        options["heartbeat_hz"] = args.heartbeat_hz
    try:
        if ids is None:
            vehicle = MockVehicle(args.connect, seed=args.seed,
                                  on_event=None if args.quiet else event, **options)
        else:
            from lamde_mission.vehicle.mock_fleet import MockFleet, vehicle_connections

            conns: str | list[str] = args.connect
            if "," in args.connect:
                conns = [c.strip() for c in args.connect.split(",")]
                if args.ports:
                    raise UsageError("--ports with several --connect: give one or the other")
            elif args.ports:
                conns = vehicle_connections(args.connect, len(ids))
            vehicle = MockFleet(conns, system_ids=ids, seed=args.seed,
                                on_event=None if args.quiet else event, **options)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    except OSError as exc:
        raise UsageError(f"--connect {args.connect}: {exc.strerror or exc}") from None
    if ids is not None:
        return _serve_fleet(vehicle)
    ep = vehicle.endpoint
    where = (f"sending to {ep.host}:{ep.port}" if ep.mode == "udpout"
             else f"listening on {ep.host}:{ep.port}")  # fmt: skip
    extras = []
    if args.loss:
        extras.append(f"loss {args.loss:g}")
    if args.loss_in:
        extras.append(f"incoming loss {args.loss_in:g}")
    if args.noisy_gcs_hz:
        extras.append(f"noisy ground station at {args.noisy_gcs_hz:g} Hz")
    if args.latency_ms:
        extras.append(f"latency {args.latency_ms:g} ms")
    if key is not None:
        extras.append("MAVLink 2 signing")
    if vehicle.reject is not None:
        from lamde_mission.vehicle.wire import mission_result_name

        extras.append(f"rejecting uploads with {mission_result_name(vehicle.reject)}")
    print(
        f"mock vehicle (system 1, component 1, quadrotor) {where}"
        + (f" ({', '.join(extras)})" if extras else "")
        + "; Ctrl-C to stop",
        flush=True,
    )
    try:
        vehicle.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        vehicle.stop()
    print(f"stopped: {_stats_line(vehicle.stats)}", file=sys.stderr)
    return 0


def _where(mode: str, host: str, port: int) -> str:
    return f"sending to {host}:{port}" if mode == "udpout" else f"listening on {host}:{port}"


def _serve_fleet(fleet: object) -> int:
    """The foreground loop of `mock-vehicle --vehicles N`: one line per link, then until Ctrl-C."""
    from lamde_mission.vehicle.mock_fleet import MockFleet
    from planner_core.textio import counted, for_count

    assert isinstance(fleet, MockFleet)
    ids = ", ".join(str(s) for s in fleet.system_ids)
    n = len(fleet.vehicles)
    what = (f"{counted(n, 'vehicle')} ({for_count(n, 'system')} {ids}, component 1, "
            f"{for_count(n, 'quadrotor')})")
    if fleet.shared:
        ep = fleet.vehicles[0].endpoint
        print(f"mock fleet: {what} on one link, {_where(ep.mode, ep.host, ep.port)}; Ctrl-C to "
              "stop", flush=True)  # fmt: skip
    else:
        print(f"mock fleet: {what}, one link each; Ctrl-C to stop", flush=True)
        for v in fleet.vehicles:
            ep = v.endpoint
            print(f"  system {v.system_id}: {_where(ep.mode, ep.host, ep.port)}", flush=True)
    try:
        fleet.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        fleet.stop()
    for v in fleet.vehicles:
        print(f"stopped system {v.system_id}: {_stats_line(v.stats)}", file=sys.stderr)
    return 0


def _stats_line(s: Any) -> str:
    """A mock's traffic when it stops: "12 messages in (0 dropped), 14 out (0 dropped), 1
    upload, 1 download" (`MockStats`)."""
    from planner_core.textio import counted

    return (f"{counted(s.received, 'message')} in ({s.dropped_in} dropped), {s.sent} out "
            f"({s.dropped} dropped), {counted(sum(s.uploads.values()), 'upload')}, "
            f"{counted(sum(s.downloads.values()), 'download')}")

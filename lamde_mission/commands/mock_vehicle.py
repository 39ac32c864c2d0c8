"""`lamde-mission mock-vehicle`: a mock autopilot to upload to, in the foreground until Ctrl-C."""

from __future__ import annotations

import argparse
import sys


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "mock-vehicle",
        help="run a mock MAVLink autopilot (no simulator needed) until Ctrl-C",
        description="Run a mock quadrotor autopilot (MAVLink 2 over UDP, system 1, component 1) "
        "that accepts mission, geofence and rally uploads and hands them back on download. "
        "Pair it with `lamde-mission upload`: by default it sends to 127.0.0.1:14540, where "
        "`upload` listens.",
    )
    p.add_argument(
        "--connect",
        default="udpout:127.0.0.1:14540",
        metavar="URL",
        help="udpout:HOST:PORT sends to a ground station listening there; "
        "udpin:HOST:PORT listens (default: %(default)s)",
    )
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
    p.add_argument("--seed", type=int, default=None, help="seed of the message loss")
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
    p.add_argument("-q", "--quiet", action="store_true", help="do not print transfer events")
    return p


def run(args: argparse.Namespace) -> int:
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
    try:
        vehicle = MockVehicle(
            args.connect, loss=args.loss, loss_in=args.loss_in, noisy_gcs_hz=args.noisy_gcs_hz,
            latency_ms=args.latency_ms, seed=args.seed,
            reject=args.reject, max_items=args.max_items, on_event=None if args.quiet else event,
            autopilot=args.autopilot, signing_key=key,
        )  # fmt: skip
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    except OSError as exc:
        raise UsageError(f"--connect {args.connect}: {exc.strerror or exc}") from None
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
    s = vehicle.stats
    print(
        f"stopped: {s.received} messages in ({s.dropped_in} dropped), {s.sent} out "
        f"({s.dropped} dropped), "
        f"{sum(s.uploads.values())} uploads, {sum(s.downloads.values())} downloads",
        file=sys.stderr,
    )
    return 0

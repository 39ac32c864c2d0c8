"""Time to connect and to upload 50 mission items, through MAVSDK and through pymavlink.

Against the mock vehicle on 127.0.0.1 (MAVLink 2 over UDP), each client in turn, `--runs` times:

- connect: from the vehicle's first HEARTBEAT to the client reporting it connected (the client
  listens first, the mock starts 0.2 s later). A client that starts while a vehicle is already
  up waits, on top, for the next 1 Hz heartbeat (0 to 1 s); `end-to-end` shows that case.
- upload 50: MISSION_COUNT to the final MISSION_ACK for 50 MISSION_ITEM_INTs;
  download 50: MISSION_REQUEST_LIST to the last item (+ our ACK).
- end-to-end: `upload_mission` (connect + mission + 5 fence items up, both read back and
  compared) with the mock already running.

    python benchmarks/bench_upload.py [--runs 10] [--loss 0.0] [--via mavsdk,pymavlink]

With `--mission` (a .plan file, or T01..T16 for the golden plan of that suite task in
tests/golden) it instead uploads that mission and its fence end to end (`upload_mission`,
default `--timeout 30 --attempts 3`) on a mock that loses `--loss` of its messages in both
directions (`--loss-in` to set the incoming side apart), and prints per client the success
rate and the median time of the successful runs; `--autopilot ardupilot` makes the mock
ArduPilot (its 1 s re-request period, home in item 0) instead of PX4 (0.25 s):

    python benchmarks/bench_upload.py --mission T16 --loss 0.4 --runs 5

Both end-to-end runs time the transfers only: `upload_mission(..., speed_check=None)` reads
no speed limit (its default reads MPC_XY_VEL_MAX first, up to 3 s on a lossy link, and warns
below the mission's speed), as when docs/upload.md's figures were measured.
"""

from __future__ import annotations

import argparse
import socket
import statistics
import threading
import time
from pathlib import Path

from lamde_mission.items import CMD, FRAME, MISSION_TYPE, MissionItem
from lamde_mission.vehicle.mock import MockVehicle
from lamde_mission.vehicle.upload import make_client, upload_mission
from lamde_mission.vehicle.wire import compare_items, wire_mission

ROOT = Path(__file__).resolve().parent.parent


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def mission(n: int = 50) -> list[MissionItem]:
    """TAKEOFF, DO_CHANGE_SPEED, n-4 LOITER_TIMEs, WAYPOINT, LAND."""
    rel, nan = FRAME.GLOBAL_RELATIVE_ALT, float("nan")
    out = [
        MissionItem(0, CMD.TAKEOFF, rel, param4=nan, x=47.3977, y=8.5456, z=80.0),
        MissionItem(1, CMD.DO_CHANGE_SPEED, FRAME.MISSION, param1=1.0, param2=15.0, param3=-1.0),
    ]
    for k in range(n - 4):
        out.append(MissionItem(len(out), CMD.LOITER_TIME, rel, param1=10.0 + k,
                               x=47.3977 + 1e-4 * k, y=8.5456 + 2e-4 * k, z=80.0))  # fmt: skip
    out.append(MissionItem(len(out), CMD.WAYPOINT, rel, param4=nan, x=47.41, y=8.56, z=80.0))
    out.append(MissionItem(len(out), CMD.LAND, rel, param4=nan, x=47.41, y=8.56, z=0.0))
    return out


def fence() -> list[MissionItem]:
    return [
        MissionItem(k, CMD.FENCE_POLYGON_VERTEX_EXCLUSION, FRAME.GLOBAL, param1=5.0,
                    x=47.40 + 1e-3 * dx, y=8.55 + 1e-3 * dy, mission_type=MISSION_TYPE.FENCE)
        for k, (dx, dy) in enumerate([(0, 0), (1, 0), (2, 1), (1, 2), (0, 1)])
    ]  # fmt: skip


def one_run(via: str, items: list, loss: float, seed: int) -> dict[str, float]:
    """Connect (first heartbeat -> connected), upload 50, download 50, on a fresh mock."""
    port = free_udp_port()
    wire = wire_mission(items)
    client = make_client(via, f"udpin://127.0.0.1:{port}")
    vehicle = MockVehicle(f"udpout:127.0.0.1:{port}", loss=loss, seed=seed)
    started: list[float] = []

    def start() -> None:
        started.append(time.perf_counter())
        vehicle.start()

    timer = threading.Timer(0.2, start)
    try:
        timer.start()
        client.connect(10.0)
        connect = time.perf_counter() - started[0]
        t0 = time.perf_counter()
        client.upload(wire, MISSION_TYPE.MISSION, 30.0)
        upload = time.perf_counter() - t0
        t0 = time.perf_counter()
        got = client.download(MISSION_TYPE.MISSION, 30.0)
        download = time.perf_counter() - t0
        assert compare_items(wire, got) == [], "read-back differs"
    finally:
        timer.cancel()
        client.close()
        vehicle.stop()
    return {"connect": connect, "upload": upload, "download": download}


def end_to_end(via: str, items: list, loss: float, seed: int) -> float:
    port = free_udp_port()
    with MockVehicle(f"udpout:127.0.0.1:{port}", loss=loss, seed=seed):
        t0 = time.perf_counter()
        report = upload_mission(items, fence(), connect=f"udpin://127.0.0.1:{port}", via=via,
                                timeout=30, attempts=5, speed_check=None)  # fmt: skip
        assert report.ok
        return time.perf_counter() - t0


def mission_file(name: str) -> Path:
    """A .plan path, or the golden plan of a suite task ("T16")."""
    p = Path(name)
    if p.suffix:
        return p
    return ROOT / "tests" / "golden" / f"{name}-seed0.plan"


def whole_mission(via: str, path: Path, loss: float, loss_in: float, seed: int, timeout: float,
                  attempts: int, noisy: float,
                  autopilot: str = "px4") -> tuple[bool, float, str]:  # fmt: skip
    """One end-to-end upload of `path`'s mission and fence: (ok, seconds, error or note)."""
    from lamde_mission.formats import read_mission
    from lamde_mission.vehicle.transfer import VehicleError

    items, fence_items = read_mission(path)
    port = free_udp_port()
    with MockVehicle(f"udpout:127.0.0.1:{port}", loss=loss, loss_in=loss_in, seed=seed,
                     noisy_gcs_hz=noisy, heartbeat_hz=4.0, autopilot=autopilot):  # fmt: skip
        t0 = time.perf_counter()
        try:
            r = upload_mission(items, fence_items, connect=f"udpin://127.0.0.1:{port}", via=via,
                               timeout=timeout, attempts=attempts, speed_check=None)  # fmt: skip
            return r.ok, time.perf_counter() - t0, f"attempt {r.attempts}"
        except VehicleError as exc:
            return False, time.perf_counter() - t0, str(exc)


def fmt(xs: list[float]) -> str:
    xs = sorted(xs)
    p90 = xs[min(len(xs) - 1, int(round(0.9 * (len(xs) - 1))))]
    return f"median {1e3 * statistics.median(xs):8.1f} ms   p90 {1e3 * p90:8.1f} ms"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--loss", type=float, default=0.0, help="fraction of the mock's messages lost")
    ap.add_argument("--via", default="mavsdk,pymavlink")
    ap.add_argument("--items", type=int, default=50)
    ap.add_argument("--mission", help="a .plan file or a suite task (T16): end-to-end runs")
    ap.add_argument("--loss-in", type=float, default=None,
                    help="fraction of the messages to the mock lost (default: --loss)")
    ap.add_argument("--noisy-gcs-hz", type=float, default=0.0,
                    help="a second ground station broadcasting mission messages at this rate")
    ap.add_argument("--timeout", type=float, default=30.0)
    ap.add_argument("--attempts", type=int, default=3)
    ap.add_argument("--autopilot", choices=("px4", "ardupilot"), default="px4",
                    help="what the mock behaves as (--mission runs)")
    ap.add_argument("--mavsdk-default-timeout", action="store_true",
                    help="leave MAVSDK's message timeout at its 0.5 s for uploads too (to "
                    "measure what the longer upload timeout of our MAVSDK client buys)")
    args = ap.parse_args()
    if args.mavsdk_default_timeout:
        import lamde_mission.vehicle.upload as up

        up._timeout_setter = lambda _sdk: None  # MavsdkClient then keeps MAVSDK's 0.5 s
    if args.mission:
        from lamde_mission.formats import read_mission

        path = mission_file(args.mission)
        m, f = read_mission(path)
        loss_in = args.loss if args.loss_in is None else args.loss_in
        print(f"{path.name}: {len(m)} mission + {len(f)} fence items; mock on 127.0.0.1 losing "
              f"{args.loss:g} of its messages out and {loss_in:g} in, noisy ground station "
              f"{args.noisy_gcs_hz:g} Hz, autopilot {args.autopilot}"
              f"{', MAVSDK timeout 0.5 s' if args.mavsdk_default_timeout else ''}; --timeout "
              f"{args.timeout:g} --attempts {args.attempts}; {args.runs} runs (seeds "
              f"0..{args.runs - 1})", flush=True)
        for via in args.via.split(","):
            res = [whole_mission(via, path, args.loss, loss_in, seed, args.timeout,
                                 args.attempts, args.noisy_gcs_hz, args.autopilot)
                   for seed in range(args.runs)]  # fmt: skip
            ok = [t for good, t, _ in res if good]
            med = f"median {statistics.median(ok):.1f} s" if ok else "no success"
            print(f"{via:10s} {len(ok)}/{len(res)} ok, {med} "
                  f"(all runs: {', '.join(f'{t:.1f}' for _, t, _ in res)} s)", flush=True)
            for seed, (good, _, note) in enumerate(res):
                if not good:
                    print(f"  seed {seed}: {note}", flush=True)
        return
    items = mission(args.items)
    print(f"mock vehicle on 127.0.0.1, loss {args.loss:g}, {args.runs} runs, "
          f"{len(items)} mission items")  # fmt: skip
    for via in args.via.split(","):
        runs = [one_run(via, items, args.loss, seed) for seed in range(args.runs)]
        e2e = [end_to_end(via, items, args.loss, seed) for seed in range(args.runs)]
        print(f"\n{via}")
        print(f"  connect (heartbeat -> connected) {fmt([r['connect'] for r in runs])}")
        print(f"  upload {len(items)} items                  {fmt([r['upload'] for r in runs])}")
        print(f"  download {len(items)} items                {fmt([r['download'] for r in runs])}")
        print(f"  end-to-end upload_mission        {fmt(e2e)}")
    print(
        "\n(end-to-end: the mock starts just before; ~1 s of it is the wait for its second "
        "1 Hz heartbeat)"
    )


if __name__ == "__main__":
    main()

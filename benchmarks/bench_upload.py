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
                                timeout=30, attempts=5)  # fmt: skip
        assert report.ok
        return time.perf_counter() - t0


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
    args = ap.parse_args()
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

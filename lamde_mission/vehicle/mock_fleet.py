"""Several mock autopilots at once: `MockFleet`, for fleet uploads without a simulator.

Two ways several vehicles reach a ground station, both as real setups have them:

- one link, several system ids (`MockFleet(connect, vehicles=3)`): every vehicle sends from one
  UDP socket, as a multi-vehicle telemetry radio, a MAVLink router or MAVProxy forwarding
  several vehicles do, and as all PX4 SITL instances reach QGroundControl on its one port
  14550 (docs.px4.io, "Multi-Vehicle Simulation": all GCS traffic goes to the same remote
  port). The ground station tells them apart by the system id of their messages only.
- one link each (`MockFleet([url1, url2, url3])`, or `vehicle_connections(connect, 3)`: the
  port of `connect` plus 0, 1, 2): PX4 SITL gives instance i its offboard-API link on UDP
  14540 + i (PX4's init.d-posix/px4-rc.mavlink, `udp_offboard_port_remote`), where MAVSDK
  and MAVROS connect one vehicle per port.

Each vehicle is a full `MockVehicle` (system id from `system_ids`, default 1..N; component 1)
with its own mission store, loss generator (seed + index) and protocol state; on one link a
vehicle answers only messages addressed to its system id (or broadcast), as an autopilot does.
"""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from lamde_mission.vehicle.mock import NOISY_GCS_SYSTEM, MockVehicle
from lamde_mission.vehicle.wire import open_udp, parse_endpoint
from planner_core.textio import counted

__all__ = ["MockFleet", "vehicle_connections", "fleet_system_ids"]

#: system ids a mock vehicle may not take: the noisy ground station's and 255, which ground
#: stations (QGroundControl, MAVSDK, our pymavlink client) use for themselves
RESERVED_SYSTEM_IDS = (NOISY_GCS_SYSTEM, 255)


def fleet_system_ids(vehicles: int | None, system_ids: Sequence[int] | None) -> list[int]:
    """The system ids of a fleet: `system_ids` as given, or 1..`vehicles`.

    Args:
        vehicles: the number of vehicles (None: as many as `system_ids`).
        system_ids: explicit MAVLink system ids, distinct, 1..253.

    Returns:
        The ids, one per vehicle, in vehicle order.

    Raises:
        ValueError: one line naming the problem (no vehicles, a count that disagrees with the
            ids, an id out of range or reserved, an id twice).
    """
    if system_ids is None:
        if vehicles is None or int(vehicles) < 1:
            raise ValueError(f"vehicles must be at least 1, got {vehicles!r}")
        if int(vehicles) > 253:
            raise ValueError(f"vehicles must be at most 253 (MAVLink system ids), got {vehicles}")
        return list(range(1, int(vehicles) + 1))
    ids = [int(s) for s in system_ids]
    if not ids:
        raise ValueError("system ids: none given")
    if vehicles is not None and int(vehicles) != len(ids):
        raise ValueError(f"{vehicles} vehicles but {len(ids)} system ids ({_join(ids)})")
    for s in ids:
        if not 1 <= s <= 255 or s in RESERVED_SYSTEM_IDS:
            raise ValueError(
                f"system id {s} is not one a mock vehicle may take (1..253; 254 is "
                "the mock's noisy ground station, 255 a ground station's)"
            )
    dup = sorted({s for s in ids if ids.count(s) > 1})
    if dup:
        raise ValueError(f"system id {_join(dup)} given twice: each vehicle needs its own")
    return ids


def _join(ids: Sequence[int]) -> str:
    return ", ".join(str(s) for s in ids)


def vehicle_connections(connect: str, n: int) -> list[str]:
    """One connection per vehicle: `connect`'s port plus 0, 1, ..., n-1 (PX4 SITL's 14540 + i).

    Args:
        connect: the first vehicle's connection, `udpout:HOST:PORT` or `udpin:HOST:PORT`.
        n: the number of vehicles.

    Returns:
        n connection strings in the same mode and host.

    Raises:
        ValueError: a bad connection, or ports past 65535.
    """
    ep = parse_endpoint(connect)
    if ep.port + n - 1 > 65535:
        raise ValueError(f"{connect}: ports {ep.port}..{ep.port + n - 1} go past 65535")
    return [f"{ep.mode}:{ep.host}:{ep.port + k}" for k in range(n)]


class MockFleet:
    """Several `MockVehicle`s, on one link (a str `connect`) or one link each (a list).

    Args:
        connect: `udpout:HOST:PORT` / `udpin:HOST:PORT` shared by all vehicles, or a list with
            one such connection per vehicle.
        vehicles: how many (default: as many as `system_ids`, else as many connections).
        system_ids: their MAVLink system ids (default 1..N), distinct.
        seed: vehicle k (0-based) gets seed + k for its message loss (default 0: the same
            losses every run; None: unseeded).
        on_event: gets each vehicle's transfer events as "system S: text".
        **options: passed to every `MockVehicle` (loss, loss_in, latency_ms, autopilot,
            reject, max_items, heartbeat_hz, corrupt, signing_key, ...).

    Raises:
        ValueError: bad counts or ids, or a bad option (one line).
        OSError: a socket cannot be opened (nothing left open).
    """

    def __init__(
        self,
        connect: str | Sequence[str] = "udpout:127.0.0.1:14540",
        *,
        vehicles: int | None = None,
        system_ids: Sequence[int] | None = None,
        seed: int | None = 0,
        on_event: Callable[[str], None] | None = None,
        **options: Any,
    ) -> None:
        shared = isinstance(connect, str)
        conns = None if shared else [str(c) for c in connect]
        if vehicles is None and system_ids is None:
            if conns is None:
                raise ValueError("give the number of vehicles or their system ids")
            vehicles = len(conns)
        self.system_ids = fleet_system_ids(vehicles, system_ids)
        n = len(self.system_ids)
        if conns is not None and len(conns) != n:
            raise ValueError(f"{counted(len(conns), 'connection')} for {counted(n, 'vehicle')}: "
                             "give one per vehicle")
        #: True: all vehicles on one socket; False: one socket each
        self.shared = shared
        self._sock: socket.socket | None = None
        self.vehicles: list[MockVehicle] = []
        try:
            if shared:
                self._sock, _peer = open_udp(parse_endpoint(str(connect)))
            for k, sid in enumerate(self.system_ids):
                self.vehicles.append(MockVehicle(
                    str(connect) if shared else conns[k],  # type: ignore[index]
                    system_id=sid, seed=None if seed is None else seed + k,
                    on_event=None if on_event is None else _prefixed(on_event, sid),
                    sock=self._sock, **options,
                ))  # fmt: skip
        except BaseException:
            self.stop()
            raise
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------------ access

    def vehicle(self, system_id: int) -> MockVehicle:
        """The vehicle with this system id.

        Args:
            system_id: its MAVLink system id.

        Returns:
            The `MockVehicle`.

        Raises:
            KeyError: no vehicle has that id.
        """
        for v in self.vehicles:
            if v.system_id == int(system_id):
                return v
        raise KeyError(f"no mock vehicle with system id {system_id}")

    def connections(self) -> list[str]:
        """Where each vehicle talks, in vehicle order (the same for all on one link).

        Returns:
            "mode:host:port" per vehicle.
        """
        return [f"{v.endpoint.mode}:{v.endpoint.host}:{v.endpoint.port}" for v in self.vehicles]

    # ------------------------------------------------------------------ life cycle

    def start(self) -> MockFleet:
        """Run every vehicle in the background (one thread per socket).

        Returns:
            self.

        Raises:
            RuntimeError: already running, or closed.
        """
        if self.shared:
            if self._thread is not None:
                raise RuntimeError("the mock fleet is already running")
            if self._sock is None:
                raise RuntimeError("the mock fleet is closed")
            self._stop.clear()
            self._thread = threading.Thread(target=self._loop, name="mock-vehicle", daemon=True)
            self._thread.start()
        else:
            for v in self.vehicles:
                v.start()
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """Stop every vehicle and close the sockets (idempotent).

        Args:
            timeout: seconds to wait for each thread to end.
        """
        stop = getattr(self, "_stop", None)
        if stop is not None:
            stop.set()
        thread = getattr(self, "_thread", None)
        if thread is not None:
            thread.join(timeout)
            self._thread = None
        for v in self.vehicles:
            v.stop(timeout)
        if self._sock is not None:
            self._sock.close()
            self._sock = None

    close = stop

    def serve_forever(self) -> None:
        """Run in the calling thread until `stop()` from elsewhere or Ctrl-C."""
        try:
            if self.shared:
                if self._sock is None:
                    raise RuntimeError("the mock fleet is closed")
                self._loop()
            else:
                self.start()
                while not self._stop.wait(0.2):
                    pass
        finally:
            self.stop()

    def __enter__(self) -> MockFleet:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _loop(self) -> None:
        """One socket, every vehicle: each vehicle's timers, then every datagram to each (a
        vehicle answers what is addressed to its system id, or broadcast)."""
        import select

        sock = self._sock
        assert sock is not None
        while not self._stop.is_set():
            now = time.monotonic()
            wait = min(v._timers(now) for v in self.vehicles)
            try:
                ready, _, _ = select.select([sock], [], [], wait)
            except (OSError, ValueError):
                break
            if not ready:
                continue
            for _ in range(64):
                try:
                    data, addr = sock.recvfrom(65536)
                except (BlockingIOError, InterruptedError, OSError):
                    break
                for v in self.vehicles:
                    v._datagram(data, addr)


def _prefixed(on_event: Callable[[str], None], system_id: int) -> Callable[[str], None]:
    def event(text: str) -> None:
        on_event(f"system {system_id}: {text}")

    return event

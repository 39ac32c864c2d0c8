"""Helpers for the tests/test_vehicle*.py files: ports, missions, a raw GCS (no tests, so not
named test_*)."""

from __future__ import annotations

import math
import random
import select
import socket
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink2

from lamde_mission.items import CMD, FRAME, MISSION_TYPE, MissionItem
from lamde_mission.vehicle.mock import MockVehicle

NAN = math.nan


@pytest.fixture(autouse=True)
def no_leftover_mock_threads() -> Iterator[None]:
    """Autouse in a module that imports it: no mock vehicle thread outlives its test."""
    yield
    left = [t for t in threading.enumerate() if t.name == "mock-vehicle" and t.is_alive()]
    assert not left, "a mock vehicle thread outlived its test"


def _ephemeral_low() -> int:
    """The first port of the kernel's ephemeral range (Linux; 32768 where it cannot be read)."""
    try:
        with open("/proc/sys/net/ipv4/ip_local_port_range") as f:
            return int(f.read().split()[0])
    except (OSError, ValueError, IndexError):
        return 32768


def free_udp_port() -> int:
    """A UDP port on 127.0.0.1 nobody uses right now, below the kernel's ephemeral range.

    A port taken by binding to port 0 comes from the ephemeral range, and once it is released
    the mock's ``udpout`` socket (bound by the kernel on its first send) may be given that same
    port before the ground side binds it: "Address already in use", about once in a few
    thousand uploads. Ports below the ephemeral range are never handed out that way.
    """
    rng = random.SystemRandom()
    top = max(_ephemeral_low(), 12_000)
    for _ in range(200):
        port = rng.randrange(10_000, top)
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            continue
        finally:
            s.close()
        return port
    raise RuntimeError("no free UDP port below the ephemeral range in 200 tries")


def hand_mission(n_hover: int = 3, *, lat: float = -35.3632, lon: float = 149.1652) -> list:
    """TAKEOFF, DO_CHANGE_SPEED, n LOITER_TIME, WAYPOINT, LAND: n + 4 items, NaN yaws included."""
    rel = FRAME.GLOBAL_RELATIVE_ALT
    out = [
        MissionItem(0, CMD.TAKEOFF, rel, param4=NAN, x=lat, y=lon, z=90.0),
        MissionItem(1, CMD.DO_CHANGE_SPEED, FRAME.MISSION, param1=1.0, param2=18.0, param3=-1.0),
    ]
    for k in range(n_hover):
        out.append(
            MissionItem(len(out), CMD.LOITER_TIME, rel, param1=12.5 + k / 3,
                        x=lat + 1.234567891e-3 * (k + 1), y=lon - 7.654321e-4 * (k + 1), z=90.0)
        )  # fmt: skip
    end = (lat + 0.01, lon + 0.02)
    out.append(MissionItem(len(out), CMD.WAYPOINT, rel, param4=NAN, x=end[0], y=end[1], z=90.0))
    out.append(MissionItem(len(out), CMD.LAND, rel, param4=NAN, x=end[0], y=end[1], z=0.0))
    return out


def hand_fence(*, lat: float = -35.3632, lon: float = 149.1652) -> list:
    """One exclusion circle and one exclusion quadrilateral: 5 FENCE items."""
    items = [
        MissionItem(0, CMD.FENCE_CIRCLE_EXCLUSION, FRAME.GLOBAL, param1=80.0,
                    x=lat + 0.002, y=lon + 0.003, mission_type=MISSION_TYPE.FENCE),
    ]  # fmt: skip
    for k, (dy, dx) in enumerate([(0, 0), (0, 1e-3), (1e-3, 1e-3), (1e-3, 0)]):
        items.append(
            MissionItem(1 + k, CMD.FENCE_POLYGON_VERTEX_EXCLUSION, FRAME.GLOBAL, param1=4.0,
                        x=lat + 0.005 + dy, y=lon + 0.005 + dx, mission_type=MISSION_TYPE.FENCE)
        )  # fmt: skip
    return items


class RawGcs:
    """A bare ground station for protocol tests: send any message, wait for a given type."""

    def __init__(self, port: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", port))
        self.sock.setblocking(False)
        self.mav = mavlink2.MAVLink(None, srcSystem=255, srcComponent=190)
        self.mav.robust_parsing = True
        self.peer: tuple[str, int] | None = None
        self.pending: list[Any] = []

    def close(self) -> None:
        self.sock.close()

    def __enter__(self) -> RawGcs:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def send(self, msg: Any) -> None:
        assert self.peer is not None, "wait for the vehicle's heartbeat first"
        self.sock.sendto(msg.pack(self.mav), self.peer)
        self.mav.seq = (self.mav.seq + 1) % 256

    def _fill(self, until: float) -> None:
        left = until - time.monotonic()
        if left <= 0:
            return
        ready, _, _ = select.select([self.sock], [], [], left)
        if ready:
            data, addr = self.sock.recvfrom(65536)
            self.peer = addr
            for m in self.mav.parse_buffer(data) or []:
                self.pending.append(m)

    def wait(self, mtype: str, timeout: float = 2.0, **fields: Any) -> Any | None:
        """The next message of `mtype` whose fields match, within `timeout` s; else None."""
        until = time.monotonic() + timeout
        while True:
            for k, m in enumerate(self.pending):
                if m.get_type() == mtype and all(getattr(m, f) == v for f, v in fields.items()):
                    del self.pending[: k + 1]
                    return m
            if time.monotonic() >= until:
                return None
            self._fill(until)

    def drain(self) -> None:
        self.pending.clear()


def mock_on(port: int, **kw: Any) -> MockVehicle:
    """A mock sending to 127.0.0.1:port; 4 Hz heartbeats so tests connect fast."""
    kw.setdefault("heartbeat_hz", 4.0)
    return MockVehicle(f"udpout:127.0.0.1:{port}", **kw)


def listen_on(port: int) -> str:
    """The ground side's connection string for a mock made by `mock_on(port)`."""
    return f"udpin://127.0.0.1:{port}"

"""A mock autopilot on pymavlink: the MAVLink mission protocol over UDP, no simulator needed.

`MockVehicle` is a quadrotor (system 1, component 1) that speaks
MAVLink 2 over UDP: HEARTBEAT at 1 Hz, AUTOPILOT_VERSION on request (MISSION_INT,
MISSION_FENCE, MISSION_RALLY and MAVLINK2 capability bits), COMMAND_ACK, and the mission
protocol for mission types MISSION, FENCE and RALLY:

- upload: MISSION_COUNT -> MISSION_REQUEST_INT ... MISSION_ITEM_INT -> MISSION_ACK. The vehicle
  drives it: it re-requests a missing item `rerequest_s` after its last request and abandons
  the upload (MISSION_ACK MAV_MISSION_OPERATION_CANCELLED) after `give_up_s` of silence, with
  the periods of the autopilot it mimics (`UPLOAD_TIMING`; MAVSDK never resends an item by
  itself, so these periods decide how it fares on a lossy link).
  A new MISSION_COUNT or MISSION_REQUEST_LIST abandons an unfinished upload (the stored list
  stays as it was): a ground station that gave up may not say so (MAVSDK does not).
- download: MISSION_REQUEST_LIST -> MISSION_COUNT; MISSION_REQUEST_INT / MISSION_REQUEST are
  answered with MISSION_ITEM_INT; the client's MISSION_ACK ends it.
- MISSION_CLEAR_ALL (one type or MAV_MISSION_TYPE_ALL), MISSION_SET_CURRENT -> MISSION_CURRENT.
- items out of turn during an upload: PX4 ignores them, ArduPilot answers
  MAV_MISSION_INVALID_SEQUENCE, and both keep asking for the item they miss; an item with no
  upload in progress is answered with MAV_MISSION_ERROR, except that PX4 takes the last item of
  the upload it just finished as a sign that its final ACK was lost and ACKs again.
- errors by MISSION_ACK: MAV_MISSION_INVALID_SEQUENCE (request past the end),
  MAV_MISSION_UNSUPPORTED (unknown mission type), MAV_MISSION_NO_SPACE (more than `max_items`),
  or the `reject` code for every MISSION_COUNT (to test how uploaders report a refusal).

`autopilot="px4"` (default) stores what it is sent; `autopilot="ardupilot"` says
MAV_AUTOPILOT_ARDUPILOTMEGA in its HEARTBEAT and stores a mission as ArduPilot does: item 0 is
its home position (`home`), whatever was sent there, and NAV_LOITER_TIME's hover seconds are
cut to a whole number.

Every message has mission_type echoed. `loss` drops that fraction of outgoing messages and
`loss_in` that fraction of incoming ones (a lossy radio both ways; drawn from `seed`, 0 by
default, so the same seed drops the same messages of the same exchange; None draws a fresh
seed), `latency_ms` delays outgoing ones. While an upload from one ground station is in
progress, mission messages from another (other system/component ids) are refused with
MAV_MISSION_DENIED addressed to it, as PX4 does, and never disturb that upload.
`noisy_gcs_hz` runs a second, noisy ground station on the same radio link: system
`NOISY_GCS_SYSTEM` broadcasting mission messages (target system 0: list requests, item
requests, items and ACKs) that both the vehicle and the ground station hear; the vehicle
answers them, addressed to system `NOISY_GCS_SYSTEM`. Run it in a background thread
(`with MockVehicle(...) as v:`) or in the foreground (`serve_forever`, what
`lamde-mission mock-vehicle` does).
"""

from __future__ import annotations

import contextlib
import heapq
import math
import random
import select
import socket
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from lamde_mission.items import MISSION_TYPE, MissionItem
from lamde_mission.vehicle.wire import (
    Endpoint,
    PacketCapture,
    WireItem,
    from_wire,
    mission_result_code,
    mission_result_name,
    mission_type_name,
    open_udp,
    parse_endpoint,
    to_wire,
)

__all__ = ["MockVehicle", "MockStats", "CAPABILITIES", "NOISY_GCS_SYSTEM", "UPLOAD_TIMING",
           "MOCK_PARAMS"]

#: system id of the mock's second, noisy ground station
NOISY_GCS_SYSTEM = 254

_m = mavlink2

#: AUTOPILOT_VERSION.capabilities of the mock
CAPABILITIES = (
    _m.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    | _m.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
    | _m.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
    | _m.MAV_PROTOCOL_CAPABILITY_MAVLINK2
)

_TYPES = (MISSION_TYPE.MISSION, MISSION_TYPE.FENCE, MISSION_TYPE.RALLY)
_MISSION_MSGS = frozenset({
    "MISSION_COUNT", "MISSION_REQUEST_LIST", "MISSION_REQUEST_INT", "MISSION_REQUEST",
    "MISSION_ITEM_INT", "MISSION_ITEM", "MISSION_ACK", "MISSION_CLEAR_ALL",
})  # fmt: skip
_TYPE_ALL = _m.MAV_MISSION_TYPE_ALL

#: How a real autopilot drives a mission upload: (re-request period s, give-up s), by dialect.
#: PX4 (src/modules/mavlink/mavlink_mission.h/.cpp, MavlinkMissionManager::send): it asks for
#: the missing item again once MAVLINK_MISSION_RETRY_TIMEOUT_DEFAULT (250 ms) has passed since
#: its last request, and drops the transfer MAVLINK_MISSION_PROTOCOL_TIMEOUT_DEFAULT (5 s) after
#: the last mission message it received from the uploader. ArduPilot
#: (libraries/GCS_MAVLink/MissionItemProtocol.cpp, update()): it asks again 1000 ms (plus the
#: link's stream slow-down, 0 on a clear link) after its last request, and cancels
#: `upload_timeout_ms` (8000 ms, MissionItemProtocol.h) after the last item it accepted.
UPLOAD_TIMING = {"px4": (0.25, 5.0), "ardupilot": (1.0, 8.0)}

#: the parameters a mock vehicle answers by default, at its autopilot's defaults: PX4's
#: multicopter horizontal speed limit MPC_XY_VEL_MAX (12 m/s; a mission's DO_CHANGE_SPEED is
#: capped at it, FlightTaskAuto) and ArduPilot Copter's WPNAV_SPEED (cm/s, the default
#: horizontal speed of a mission)
MOCK_PARAMS: dict[str, dict[str, float]] = {"px4": {"MPC_XY_VEL_MAX": 12.0},
                                            "ardupilot": {"WPNAV_SPEED": 1000.0}}


@dataclass
class MockStats:
    """Message counters (for tests and the foreground summary)."""

    received: int = 0
    sent: int = 0
    dropped: int = 0
    dropped_in: int = 0
    noise: int = 0
    denied_others: int = 0
    rerequests: int = 0
    uploads: dict[int, int] = field(default_factory=lambda: dict.fromkeys(_TYPES, 0))
    downloads: dict[int, int] = field(default_factory=lambda: dict.fromkeys(_TYPES, 0))


@dataclass
class _Upload:
    mission_type: int
    count: int
    items: list[WireItem]
    last_request: float
    src: tuple[int, int] = (0, 0)
    last_heard: float = 0.0  # the last mission message of this upload from its ground station
    last_item: float = 0.0  # the last item accepted (or the MISSION_COUNT)


class MockVehicle:
    """A mock quadrotor autopilot (MAVLink 2 over UDP) that stores what it is sent.

    `connect` is where it talks: `udpout:HOST:PORT` sends to a ground station listening there
    (MAVSDK's `udpin://`), `udpin:HOST:PORT` listens and answers whoever wrote last.
    `reject` (a MAV_MISSION_RESULT code or name) makes it refuse every upload with that code;
    `lose_in` / `lose_out` (functions of a MAVLink message) lose the received / sent messages
    they return True for, on top of `loss_in` / `loss` (a loss pattern a test can count on);
    `corrupt` (a function of a received WireItem) makes it store something else (a faulty
    vehicle, to test the read-back comparison). `sock` (for `mock_fleet.MockFleet`) is a UDP
    socket shared with other mock vehicles, opened for `connect` by the caller, who runs the
    loop and closes it.
    """

    def __init__(
        self,
        connect: str = "udpout:127.0.0.1:14540",
        *,
        loss: float = 0.0,
        loss_in: float = 0.0,
        noisy_gcs_hz: float = 0.0,
        latency_ms: float = 0.0,
        seed: int | None = 0,
        reject: int | str | None = None,
        max_items: int = 1000,
        rerequest_s: float | None = None,
        give_up_s: float | None = None,
        heartbeat_hz: float = 1.0,
        system_id: int = 1,
        component_id: int = 1,
        corrupt: Callable[[WireItem], WireItem] | None = None,
        lose_in: Callable[[object], bool] | None = None,
        lose_out: Callable[[object], bool] | None = None,
        on_event: Callable[[str], None] | None = None,
        autopilot: str = "px4",
        home: tuple[float, float, float] = (-35.3632621, 149.1652374, 584.0),
        signing_key: bytes | None = None,
        sock: socket.socket | None = None,
        params: dict[str, float] | None = None,
    ) -> None:
        if not 0.0 <= loss < 1.0:
            raise ValueError(f"loss must be in [0, 1), got {loss!r}")
        if not 0.0 <= loss_in < 1.0:
            raise ValueError(f"loss_in must be in [0, 1), got {loss_in!r}")
        if not 0.0 <= noisy_gcs_hz <= 1000.0:
            raise ValueError(f"noisy_gcs_hz must be in [0, 1000], got {noisy_gcs_hz!r}")
        if latency_ms < 0:
            raise ValueError(f"latency_ms must be >= 0, got {latency_ms!r}")
        if max_items < 0:
            raise ValueError(f"max_items must be >= 0, got {max_items!r}")
        self.endpoint: Endpoint = parse_endpoint(connect)
        self.loss = float(loss)
        self.loss_in = float(loss_in)
        self.noisy_gcs_hz = float(noisy_gcs_hz)
        self.latency = float(latency_ms) / 1000.0
        self.seed = seed
        self.reject = None if reject is None else mission_result_code(reject)
        self.max_items = int(max_items)
        if autopilot not in UPLOAD_TIMING:
            raise ValueError(f"autopilot must be 'px4' or 'ardupilot', got {autopilot!r}")
        period, give_up = UPLOAD_TIMING[autopilot]
        # the autopilot's period; with `latency_ms`, at least one round trip (a real one asks
        # again regardless, and ignores the crossing duplicate)
        self.rerequest_s = (
            float(rerequest_s) if rerequest_s is not None else max(period, 2 * self.latency + 0.05)
        )
        self.give_up_s = float(give_up_s) if give_up_s is not None else give_up
        self.heartbeat_period = 1.0 / float(heartbeat_hz)
        self.system_id = int(system_id)
        self.component_id = int(component_id)
        self.corrupt = corrupt
        self.lose_in = lose_in
        self.lose_out = lose_out
        self.autopilot = autopilot
        #: the parameters the vehicle answers PARAM_REQUEST_READ / _LIST with: its autopilot's
        #: defaults (`MOCK_PARAMS`), updated by `params`
        self.params: dict[str, float] = {**MOCK_PARAMS.get(autopilot, {}),
                                         **{str(k): float(v) for k, v in (params or {}).items()}}
        for k in self.params:
            if not 0 < len(k) <= 16:
                raise ValueError(f"params: a MAVLink parameter id has 1..16 characters, got {k!r}")
        self.home = tuple(float(v) for v in home)
        self.on_event = on_event
        self.stats = MockStats()

        self._rng = random.Random(seed)
        self._rng_in = random.Random(None if seed is None else seed + 7919)
        self._rng_noise = random.Random(None if seed is None else seed + 104729)
        self._noise_mav = _m.MAVLink(
            PacketCapture(), srcSystem=NOISY_GCS_SYSTEM, srcComponent=_m.MAV_COMP_ID_MISSIONPLANNER
        )
        self._next_noise = 0.0
        self._mav = _m.MAVLink(
            PacketCapture(), srcSystem=self.system_id, srcComponent=self.component_id
        )
        self._mav.robust_parsing = True
        if signing_key is not None:  # MAVLink 2 signing: sign all, hear only the signed
            from lamde_mission.vehicle.signing import enable_signing

            enable_signing(self._mav, signing_key, link_id=1)
        self._lock = threading.Lock()
        self._store: dict[int, list[WireItem]] = {t: [] for t in _TYPES}
        self._upload: _Upload | None = None
        self._completed: tuple[int, int] | None = None  # (mission_type, count) of the last upload
        self._current = 0
        self._outbox: list[tuple[float, int, bytes]] = []
        self._outbox_n = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._sock: socket.socket | None = None
        self._peer: tuple[str, int] | None = None
        self._next_heartbeat = 0.0
        #: whether the socket is this vehicle's own (closed by `stop`), not a fleet's
        self._owns_sock = sock is None
        if sock is None:
            self._open()
        else:  # a socket shared with other vehicles (`mock_fleet.MockFleet` runs the loop)
            self._sock = sock
            if self.endpoint.mode == "udpout":
                self._peer = (socket.gethostbyname(self.endpoint.host), self.endpoint.port)

    # ------------------------------------------------------------------ life cycle

    def _open(self) -> None:
        sock, peer = open_udp(self.endpoint)
        if peer is not None:
            self._peer = peer
        self._sock = sock

    @property
    def address(self) -> tuple[str, int]:
        """The local (host, port) the mock's socket is bound to.

        Returns:
            The socket's `getsockname()`.

        Raises:
            RuntimeError: the mock vehicle is closed.
        """
        if self._sock is None:
            raise RuntimeError("the mock vehicle is closed")
        return self._sock.getsockname()

    def start(self) -> MockVehicle:
        """Run the vehicle in a background thread.

        Returns:
            self.

        Raises:
            RuntimeError: already running, closed, or sharing its socket (its fleet runs it).
        """
        if self._thread is not None:
            raise RuntimeError("the mock vehicle is already running")
        if self._sock is None:
            raise RuntimeError("the mock vehicle is closed")
        if not self._owns_sock:
            raise RuntimeError("the mock vehicle shares its socket: its fleet runs it")
        self._stop.clear()
        self._thread = threading.Thread(target=self._loop, name="mock-vehicle", daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """Stop the background thread and close the socket (idempotent).

        Args:
            timeout: seconds to wait for the thread to end.
        """
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)
            self._thread = None
        if self._sock is not None:
            if self._owns_sock:
                self._sock.close()
            self._sock = None

    close = stop

    def serve_forever(self) -> None:
        """Run in the calling thread until `stop()` is called from elsewhere or Ctrl-C."""
        if self._sock is None:
            raise RuntimeError("the mock vehicle is closed")
        try:
            self._loop()
        finally:
            self.stop()

    def __enter__(self) -> MockVehicle:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ------------------------------------------------------------------ stored lists

    def wire_items(self, mission_type: int = MISSION_TYPE.MISSION) -> list[WireItem]:
        """The list stored for `mission_type`, exactly as received.

        Args:
            mission_type: MAV_MISSION_TYPE mission, fence or rally.

        Returns:
            A copy of the stored list.

        Raises:
            KeyError: another mission type.
        """
        with self._lock:
            return list(self._store[int(mission_type)])

    def items(self, mission_type: int = MISSION_TYPE.MISSION) -> list[MissionItem]:
        """The list stored for `mission_type` as MissionItems (lat/lon back in degrees).

        Args:
            mission_type: MAV_MISSION_TYPE mission, fence or rally.

        Returns:
            The items (`from_wire`).

        Raises:
            KeyError: another mission type.
        """
        return [from_wire(w) for w in self.wire_items(mission_type)]

    def set_items(
        self, items: Sequence[MissionItem | WireItem], mission_type: int | None = None
    ) -> None:
        """Store a list as if it had been uploaded.

        Args:
            items: the list; MissionItems are converted with seq renumbered from 0
                (`to_wire`), WireItems are stored as given.
            mission_type: the list to store it as; None: the first item's type (mission for
                an empty list).

        Raises:
            ValueError: an unsupported mission type, or a MissionItem MAVLink cannot carry.
        """
        wire = [w if isinstance(w, WireItem) else to_wire(w, seq=k) for k, w in enumerate(items)]
        t = int(mission_type if mission_type is not None else (wire[0].mission_type if wire else 0))
        if t not in _TYPES:
            raise ValueError(f"unsupported mission type {t}")
        with self._lock:
            self._store[t] = wire

    @property
    def peer(self) -> tuple[str, int] | None:
        """Where the mock sends.

        Returns:
            (host, port), or None for udpin until someone has written to it.
        """
        return self._peer

    # ------------------------------------------------------------------ the loop

    def _event(self, text: str) -> None:
        if self.on_event is not None:
            self.on_event(text)

    def _loop(self) -> None:
        sock = self._sock
        assert sock is not None
        while not self._stop.is_set():
            wait = self._timers(time.monotonic())
            try:
                ready, _, _ = select.select([sock], [], [], wait)
            except (OSError, ValueError):
                break
            if not ready:
                continue
            for _ in range(64):  # drain what is there
                try:
                    data, addr = sock.recvfrom(65536)
                except (BlockingIOError, InterruptedError):
                    break
                except OSError:  # e.g. ICMP port unreachable reported on some systems
                    break
                self._datagram(data, addr)

    def _timers(self, now: float) -> float:
        """What is due at `now` (heartbeat, re-request or give-up, noise, delayed sends);
        returns how long the loop may wait for input (s)."""
        if self._peer is not None and now >= self._next_heartbeat:
            self._send_heartbeat()
            self._next_heartbeat = now + self.heartbeat_period
        self._tick(now)
        if self.noisy_gcs_hz > 0 and self._peer is not None and now >= self._next_noise:
            self._next_noise = now + 1.0 / self.noisy_gcs_hz
            self._noise()
        self._flush(now)
        wait = 0.02 if self._upload is not None else 0.1
        if self.noisy_gcs_hz > 0:
            wait = min(wait, max(self._next_noise - now, 0.0))
        if self._outbox:
            wait = min(wait, self._outbox[0][0] - now)
        if self._peer is not None:
            wait = min(wait, self._next_heartbeat - now)
        return max(wait, 0.0)

    def _datagram(self, data: bytes, addr: tuple[str, int]) -> None:
        """One received datagram: incoming loss, the udpin peer, then each message handled."""
        if self.loss_in > 0.0 and self._rng_in.random() < self.loss_in:
            self.stats.dropped_in += 1
            return
        if self.endpoint.mode == "udpin" and addr != self._peer:
            self._peer = addr
            self._next_heartbeat = 0.0
        try:
            msgs = self._mav.parse_buffer(data) or []
        except Exception:  # a malformed datagram must not stop the vehicle
            return
        for msg in msgs:
            if self.lose_in is not None and self.lose_in(msg):
                self.stats.dropped_in += 1
                continue
            with self._lock:
                self._handle(msg)

    def _tick(self, now: float) -> None:
        """Vehicle-side re-request of a missing upload item `rerequest_s` after the last
        request; give up after `give_up_s` without a mission message from the ground station
        (PX4) or without a new item (ArduPilot)."""
        with self._lock:
            up = self._upload
            if up is None:
                return
            since = up.last_heard if self.autopilot == "px4" else up.last_item
            if now - since > self.give_up_s:
                self._upload = None
                self._event(
                    f"{mission_type_name(up.mission_type)} upload abandoned: no item "
                    f"{len(up.items)} after {self.give_up_s:g} s"
                )
                self._ack(_m.MAV_MISSION_OPERATION_CANCELLED, up.mission_type, up.src)
                return
            if now - up.last_request < self.rerequest_s:
                return
            self.stats.rerequests += 1
            self._request(up, now)

    def _noise(self) -> None:
        """One broadcast mission message of the noisy ground station: heard by the vehicle
        (handled as from system NOISY_GCS_SYSTEM) and sent on the link to the ground station."""
        r = self._rng_noise
        t = r.choice(_TYPES)
        kind = r.randrange(4)
        # no MISSION_COUNT or MISSION_CLEAR_ALL: a ground station that uploads or clears
        # holds or changes the vehicle's lists for real (PX4 and ArduPilot serve one transfer
        # at a time); this one only reads, re-requests and acknowledges, addressed to everyone
        if kind == 0:
            msg = _m.MAVLink_mission_request_list_message(0, 0, t)
        elif kind == 1:
            msg = _m.MAVLink_mission_request_int_message(0, 0, r.randrange(0, 400), t)
        elif kind == 2:
            msg = _m.MAVLink_mission_ack_message(0, 0, r.choice(
                [_m.MAV_MISSION_ACCEPTED, _m.MAV_MISSION_ERROR, _m.MAV_MISSION_DENIED]), t)
        else:
            msg = _m.MAVLink_mission_item_int_message(
                0, 0, r.randrange(0, 400), _m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                _m.MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0, 0, 0, 0, 0, 10.0, t)
        self._noise_mav.send(msg)
        buf = self._noise_mav.file.buf
        self.stats.noise += 1
        self._sendto(buf)  # the ground station hears it on the shared link
        for heard in self._mav.parse_buffer(buf) or []:  # and so does the vehicle
            with self._lock:
                self._handle(heard)

    def _busy_with_other(self, msg: object, src: tuple[int, int]) -> bool:
        """An upload from another ground station is in progress: refuse `msg` (PX4: DENIED)."""
        up = self._upload
        if up is None or src == up.src or msg.get_type() not in _MISSION_MSGS:
            return False
        self.stats.denied_others += 1
        if msg.get_type() != "MISSION_ACK":
            self._ack(_m.MAV_MISSION_DENIED, int(getattr(msg, "mission_type", 0)), src)
        return True

    def _flush(self, now: float) -> None:
        while self._outbox and self._outbox[0][0] <= now:
            _, _, buf = heapq.heappop(self._outbox)
            self._sendto(buf)

    # ------------------------------------------------------------------ sending

    def _sendto(self, buf: bytes) -> None:
        if self._sock is None or self._peer is None:
            return
        # nobody listening yet: a radio link would lose it too
        with contextlib.suppress(OSError):
            self._sock.sendto(buf, self._peer)

    def _send(self, msg: object) -> None:
        cap = self._mav.file
        self._mav.send(msg)
        self.stats.sent += 1
        if self.lose_out is not None and self.lose_out(msg):
            self.stats.dropped += 1
            return
        if self.loss > 0.0 and self._rng.random() < self.loss:
            self.stats.dropped += 1
            return
        if self.latency > 0.0:
            self._outbox_n += 1
            heapq.heappush(self._outbox, (time.monotonic() + self.latency, self._outbox_n, cap.buf))
        else:
            self._sendto(cap.buf)

    def _send_heartbeat(self) -> None:
        self._send(
            _m.MAVLink_heartbeat_message(
                _m.MAV_TYPE_QUADROTOR,
                _m.MAV_AUTOPILOT_ARDUPILOTMEGA if self.autopilot == "ardupilot"
                else _m.MAV_AUTOPILOT_PX4,
                _m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 0, _m.MAV_STATE_STANDBY, 3,
            )
        )  # fmt: skip

    def _ack(self, code: int, mission_type: int, to: tuple[int, int] = (0, 0)) -> None:
        self._send(_m.MAVLink_mission_ack_message(to[0], to[1], code, mission_type))

    def _request(self, up: _Upload, now: float) -> None:
        up.last_request = now
        self._send(
            _m.MAVLink_mission_request_int_message(
                up.src[0], up.src[1], len(up.items), up.mission_type
            )
        )

    def _command_ack(self, command: int, result: int, src: tuple[int, int]) -> None:
        self._send(_m.MAVLink_command_ack_message(command, result, 0, 0, src[0], src[1]))

    def _autopilot_version(self) -> None:
        self._send(
            _m.MAVLink_autopilot_version_message(
                CAPABILITIES, 0x010E0000, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0, 0, [0] * 18
            )
        )

    # ------------------------------------------------------------------ receiving

    def _for_me(self, msg: object) -> bool:
        ts = getattr(msg, "target_system", 0)
        tc = getattr(msg, "target_component", 0)
        return ts in (0, self.system_id) and tc in (0, self.component_id)

    def _handle(self, msg: object) -> None:
        self.stats.received += 1
        name = msg.get_type()
        if name in ("BAD_DATA", "HEARTBEAT") or not self._for_me(msg):
            return
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        if self._busy_with_other(msg, src):
            return
        handler = getattr(self, "_on_" + name.lower(), None)
        if handler is not None:
            handler(msg, src)

    def _on_command_long(self, msg: object, src: tuple[int, int]) -> None:
        cmd = int(msg.command)
        if cmd == _m.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES or (
            cmd == _m.MAV_CMD_REQUEST_MESSAGE
            and int(msg.param1) == _m.MAVLINK_MSG_ID_AUTOPILOT_VERSION
        ):
            self._command_ack(cmd, _m.MAV_RESULT_ACCEPTED, src)
            self._autopilot_version()
        elif cmd == _m.MAV_CMD_REQUEST_MESSAGE and int(msg.param1) == _m.MAVLINK_MSG_ID_HEARTBEAT:
            self._command_ack(cmd, _m.MAV_RESULT_ACCEPTED, src)
            self._send_heartbeat()
        else:
            self._command_ack(cmd, _m.MAV_RESULT_UNSUPPORTED, src)

    def _param_value(self, name: str) -> None:
        names = list(self.params)
        self._send(self._mav.param_value_encode(
            name.encode(), float(self.params[name]), _m.MAV_PARAM_TYPE_REAL32, len(names),
            names.index(name)))  # fmt: skip

    def _on_param_request_read(self, msg: object, src: tuple[int, int]) -> None:
        """PARAM_VALUE for a known parameter (by id, or by index when param_index >= 0);
        nothing for an unknown one, as PX4 and ArduPilot answer."""
        names = list(self.params)
        index = int(msg.param_index)
        name = names[index] if 0 <= index < len(names) else (
            str(msg.param_id).rstrip("\x00") if index < 0 else None)
        if name in self.params:
            self._param_value(name)

    def _on_param_request_list(self, msg: object, src: tuple[int, int]) -> None:
        for name in self.params:
            self._param_value(name)

    def _on_command_int(self, msg: object, src: tuple[int, int]) -> None:
        self._command_ack(int(msg.command), _m.MAV_RESULT_UNSUPPORTED, src)

    def _on_mission_count(self, msg: object, src: tuple[int, int]) -> None:
        t, count = int(msg.mission_type), int(msg.count)
        self._completed = None
        if self._upload is not None:
            old = self._upload
            if not (old.mission_type == t and old.count == count and not old.items):
                self._event(
                    f"{mission_type_name(old.mission_type)} upload abandoned at item "
                    f"{len(old.items)} of {old.count} (new MISSION_COUNT)"
                )
            self._upload = None
        if t not in _TYPES:
            self._ack(_m.MAV_MISSION_UNSUPPORTED, t, src)
            return
        if self.reject is not None:
            self._event(
                f"{mission_type_name(t)} upload of {count} items rejected: "
                f"{mission_result_name(self.reject)}"
            )
            self._ack(self.reject, t, src)
            return
        if count > self.max_items:
            self._event(f"{mission_type_name(t)} upload of {count} items rejected: no space")
            self._ack(_m.MAV_MISSION_NO_SPACE, t, src)
            return
        if count == 0:
            self._store[t] = []
            self._completed = (t, 0)
            self.stats.uploads[t] += 1
            self._event(f"{mission_type_name(t)} cleared (empty upload)")
            self._ack(_m.MAV_MISSION_ACCEPTED, t, src)
            return
        now = time.monotonic()
        self._upload = _Upload(t, count, [], 0.0, src, last_heard=now, last_item=now)
        self._request(self._upload, now)

    def _on_mission_item_int(self, msg: object, src: tuple[int, int], scaled: bool = True) -> None:
        t, seq = int(msg.mission_type), int(msg.seq)
        up = self._upload
        if up is None or up.mission_type != t:
            if self.autopilot == "px4" and self._completed == (t, seq + 1):
                # PX4: the last item again means the final ACK was lost: ACK again
                self._ack(_m.MAV_MISSION_ACCEPTED, t, src)
            else:  # no transfer of this type: PX4 and ArduPilot answer MAV_MISSION_ERROR
                self._ack(_m.MAV_MISSION_ERROR, t, src)
            return
        expected = len(up.items)
        up.last_heard = time.monotonic()
        if seq != expected:
            # not the item asked for (a duplicate that crossed a re-request, or a skip): PX4
            # ignores it; ArduPilot answers MAV_MISSION_INVALID_SEQUENCE. Both go on asking.
            if self.autopilot == "ardupilot":
                self._ack(_m.MAV_MISSION_INVALID_SEQUENCE, t, src)
            return
        if scaled:
            item = WireItem(seq, int(msg.frame), int(msg.command), int(msg.current),
                            int(msg.autocontinue), float(msg.param1), float(msg.param2),
                            float(msg.param3), float(msg.param4), int(msg.x), int(msg.y),
                            float(msg.z), t)  # fmt: skip
        else:  # MISSION_ITEM (float x/y): stored as MISSION_ITEM_INT would carry it
            item = to_wire(
                MissionItem(seq, int(msg.command), int(msg.frame), int(msg.current),
                            int(msg.autocontinue), msg.param1, msg.param2, msg.param3,
                            msg.param4, msg.x, msg.y, msg.z, t)
            )  # fmt: skip
        if self.autopilot == "ardupilot" and t == MISSION_TYPE.MISSION:
            item = self._ardupilot_stores(item)
        if self.corrupt is not None:
            item = self.corrupt(item)
        up.items.append(item)
        up.last_item = up.last_heard
        if len(up.items) == up.count:
            self._store[t] = list(up.items)
            self._upload = None
            self._completed = (t, up.count)
            self.stats.uploads[t] += 1
            self._event(f"{mission_type_name(t)} received: {up.count} items")
            self._ack(_m.MAV_MISSION_ACCEPTED, t, src)
        else:
            self._request(up, time.monotonic())

    def _ardupilot_stores(self, item: WireItem) -> WireItem:
        """What ArduPilot keeps of a mission item: item 0 is its home position (whatever was
        sent), NAV_LOITER_TIME's hover seconds a whole number (uint16, fraction cut off)."""
        if item.seq == 0:
            lat, lon, alt = self.home
            return WireItem(0, _m.MAV_FRAME_GLOBAL, _m.MAV_CMD_NAV_WAYPOINT, 0, 1, 0.0, 0.0,
                            0.0, 0.0, int(round(lat * 1e7)), int(round(lon * 1e7)),
                            float(np.float32(alt)), item.mission_type)  # fmt: skip
        if item.command == _m.MAV_CMD_NAV_LOITER_TIME and math.isfinite(item.param1):
            return replace(item, param1=float(min(max(int(item.param1), 0), 65535)))
        return item

    def _on_mission_item(self, msg: object, src: tuple[int, int]) -> None:
        self._on_mission_item_int(msg, src, scaled=False)

    def _on_mission_request_list(self, msg: object, src: tuple[int, int]) -> None:
        t = int(msg.mission_type)
        if t not in _TYPES:
            self._ack(_m.MAV_MISSION_UNSUPPORTED, t, src)
            return
        if self._upload is not None:  # the ground station gave up on it (MAVSDK says nothing)
            old = self._upload
            self._event(
                f"{mission_type_name(old.mission_type)} upload abandoned at item "
                f"{len(old.items)} of {old.count} (download requested)"
            )
            self._upload = None
        self._send(_m.MAVLink_mission_count_message(src[0], src[1], len(self._store[t]), t))

    def _on_mission_request_int(self, msg: object, src: tuple[int, int]) -> None:
        t, seq = int(msg.mission_type), int(msg.seq)
        if t not in _TYPES:
            self._ack(_m.MAV_MISSION_UNSUPPORTED, t, src)
            return
        if self._upload is not None and self._upload.mission_type == t:
            self._ack(_m.MAV_MISSION_DENIED, t, src)  # busy receiving that list
            return
        items = self._store[t]
        if not 0 <= seq < len(items):
            self._ack(_m.MAV_MISSION_INVALID_SEQUENCE, t, src)
            return
        w = items[seq]
        self._send(_m.MAVLink_mission_item_int_message(src[0], src[1], *w.fields()))

    _on_mission_request = _on_mission_request_int

    def _on_mission_ack(self, msg: object, src: tuple[int, int]) -> None:
        t = int(msg.mission_type)
        if int(msg.type) == _m.MAV_MISSION_ACCEPTED:
            if t in _TYPES and self._upload is None:
                self.stats.downloads[t] += 1
                self._event(f"{mission_type_name(t)} sent: {len(self._store[t])} items")
            return
        if self._upload is not None and self._upload.mission_type == t:
            self._event(
                f"{mission_type_name(t)} upload cancelled by the ground station "
                f"({mission_result_name(int(msg.type))})"
            )
            self._upload = None

    def _on_mission_clear_all(self, msg: object, src: tuple[int, int]) -> None:
        t = int(msg.mission_type)
        if t == _TYPE_ALL:
            for k in _TYPES:
                self._store[k] = []
        elif t in _TYPES:
            self._store[t] = []
        else:
            self._ack(_m.MAV_MISSION_UNSUPPORTED, t, src)
            return
        if self._upload is not None and t in (_TYPE_ALL, self._upload.mission_type):
            self._upload = None
        self._completed = None
        self._event(f"{'all lists' if t == _TYPE_ALL else mission_type_name(t)} cleared")
        self._ack(_m.MAV_MISSION_ACCEPTED, t, src)

    def _on_mission_set_current(self, msg: object, src: tuple[int, int]) -> None:
        seq = int(msg.seq)
        n = len(self._store[MISSION_TYPE.MISSION])
        if 0 <= seq < n:
            self._current = seq
        self._send(_m.MAVLink_mission_current_message(self._current, n, 0, 0))

"""A mission uploader on pymavlink alone: the ground-station side of the MAVLink mission protocol.

`MavlinkClient` talks MAVLink 2 over UDP (`udpin://HOST:PORT` listens for the vehicle,
`udpout://HOST:PORT` sends to it) and is a `MissionClient` for `transfer.upload_and_verify`.
Where the protocol leaves retries to the ground station it retries after a silence:
MISSION_COUNT, MISSION_REQUEST_LIST, MISSION_REQUEST_INT and MISSION_CLEAR_ALL are resent, and so
is the last item when the final MISSION_ACK does not come (a vehicle that got it answers with the
ACK again). The silence waited for adapts to the link as TCP's retransmission timeout does:
`item_timeout` until a round trip has been measured, then 4x the smoothed round trip (at least
`min_timeout`), doubled after each silence for the same message up to `max_timeout`. Every call
ends by its `timeout`.
"""

from __future__ import annotations

import collections
import select
import socket
import time
from collections.abc import Callable, Sequence
from typing import Any

from pymavlink.dialects.v20 import common as mavlink2

from lamde_mission.vehicle.transfer import (
    RETRYABLE_ACKS,
    MissionRejectedError,
    NoVehicleError,
    TransferError,
    VehicleError,
    VehicleInfo,
)
from lamde_mission.vehicle.wire import (
    Endpoint,
    PacketCapture,
    WireItem,
    mission_result_name,
    mission_type_name,
    open_udp,
    parse_endpoint,
    to_wire,
)

__all__ = ["MavlinkClient"]

_m = mavlink2


class MavlinkClient:
    """Ground-station side of the mission protocol over UDP (pymavlink messages, our sockets)."""

    name = "pymavlink"

    def __init__(
        self,
        connect: str = "udpin://0.0.0.0:14540",
        *,
        item_timeout: float = 0.25,
        min_timeout: float = 0.05,
        max_timeout: float = 2.0,
        max_retries: int = 10,
        system_id: int = 255,
        component_id: int = _m.MAV_COMP_ID_MISSIONPLANNER,
    ) -> None:
        self.endpoint: Endpoint = parse_endpoint(connect)
        self.item_timeout = float(item_timeout)
        self.min_timeout = float(min_timeout)
        self.max_timeout = float(max_timeout)
        self.max_retries = int(max_retries)
        self._srtt: float | None = None
        self._rto = self.item_timeout
        self.system_id = int(system_id)
        self.component_id = int(component_id)
        self.vehicle: VehicleInfo | None = None
        self._mav = _m.MAVLink(
            PacketCapture(), srcSystem=self.system_id, srcComponent=self.component_id
        )
        self._mav.robust_parsing = True
        self._pending: collections.deque[Any] = collections.deque()
        self._peer: tuple[str, int] | None = None
        self._next_heartbeat = 0.0
        ep = self.endpoint
        try:
            sock, self._peer = open_udp(ep)
        except OSError as exc:
            raise VehicleError(f"cannot open {ep}: {exc.strerror or exc}") from None
        self._sock: socket.socket | None = sock

    # ------------------------------------------------------------------ life cycle

    def close(self) -> None:
        """Close the socket (idempotent)."""
        if self._sock is not None:
            self._sock.close()
            self._sock = None

    def __enter__(self) -> MavlinkClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ transport

    def _send(self, msg: Any) -> None:
        if self._sock is None:
            raise TransferError("the connection is closed")
        self._mav.send(msg)
        if self._peer is not None:
            try:
                self._sock.sendto(self._mav.file.buf, self._peer)
            except OSError as exc:
                host, port = self._peer
                raise TransferError(f"cannot send to {host}:{port} ({exc})") from None

    def _heartbeat_if_due(self) -> None:
        now = time.monotonic()
        if self._peer is not None and now >= self._next_heartbeat:
            self._next_heartbeat = now + 1.0
            self._send(
                _m.MAVLink_heartbeat_message(
                    _m.MAV_TYPE_GCS, _m.MAV_AUTOPILOT_INVALID, 0, 0, _m.MAV_STATE_ACTIVE, 3
                )
            )

    def _rtt_sample(self, rtt: float) -> None:
        """Smoothed round trip (Karn: only from answers to a message sent once)."""
        self._srtt = rtt if self._srtt is None else 0.875 * self._srtt + 0.125 * rtt
        self._reset_rto()

    def _reset_rto(self) -> None:
        """Back to the timeout the measured round trip gives (after progress)."""
        if self._srtt is None:
            self._rto = self.item_timeout
        else:
            self._rto = min(max(4.0 * self._srtt, self.min_timeout), self.max_timeout)

    def _backoff(self) -> None:
        self._rto = min(2.0 * self._rto, self.max_timeout)

    @property
    def retry_timeout(self) -> float:
        """The silence (s) after which the next message is resent."""
        return self._rto

    def _from_vehicle(self, msg: Any) -> bool:
        v = self.vehicle
        if v is None or (msg.get_srcSystem(), msg.get_srcComponent()) != (
            v.system_id,
            v.component_id,
        ):
            return False
        ts = getattr(msg, "target_system", 0)
        return ts in (0, self.system_id)

    def _recv(self, until: float, accept: Callable[[Any], bool]) -> Any | None:
        """The first message that `accept`s before `until` (monotonic), else None."""
        while True:
            while self._pending:
                msg = self._pending.popleft()
                if accept(msg):
                    return msg
            self._heartbeat_if_due()
            left = until - time.monotonic()
            if left <= 0 or self._sock is None:
                return None
            ready, _, _ = select.select([self._sock], [], [], min(left, 0.2))
            if not ready:
                continue
            for _ in range(64):
                try:
                    data, addr = self._sock.recvfrom(65536)
                except (BlockingIOError, InterruptedError):
                    break
                except OSError:
                    break
                try:
                    msgs = self._mav.parse_buffer(data) or []
                except Exception:
                    continue
                for msg in msgs:
                    if msg.get_type() == "BAD_DATA":
                        continue
                    msg._lamde_addr = addr
                    self._pending.append(msg)

    # ------------------------------------------------------------------ connect

    def connect(self, timeout: float) -> VehicleInfo:
        """Wait up to `timeout` s for an autopilot's HEARTBEAT (component 1); NoVehicleError."""
        deadline = time.monotonic() + timeout

        def autopilot(msg: Any) -> bool:
            return (msg.get_type() == "HEARTBEAT"
                    and msg.get_srcComponent() == _m.MAV_COMP_ID_AUTOPILOT1
                    and msg.autopilot != _m.MAV_AUTOPILOT_INVALID)  # fmt: skip

        hb = self._recv(deadline, autopilot)
        if hb is None:
            raise NoVehicleError(f"no vehicle heard at {self.endpoint} within {timeout:g} s")
        if self.endpoint.mode == "udpin":
            self._peer = hb._lamde_addr
            self._next_heartbeat = 0.0
        self.vehicle = VehicleInfo.from_heartbeat(hb)
        self._heartbeat_if_due()
        return self.vehicle

    def _target(self) -> tuple[int, int]:
        if self.vehicle is None:
            raise TransferError("not connected (call connect first)")
        return self.vehicle.system_id, self.vehicle.component_id

    # ------------------------------------------------------------------ the protocol

    def _exchange(
        self,
        send: Callable[[], None],
        accept: Callable[[Any], bool],
        deadline: float,
        what: str,
    ) -> Any:
        """Send, wait for an accepted answer, resend after a silence; TransferError at the end.

        The silence doubles with each resend of this message only: on a lossy radio a lost
        message says nothing about the next one (no congestion to back off from).
        """
        self._reset_rto()
        for k in range(self.max_retries + 1):
            t0 = time.monotonic()
            send()
            msg = self._recv(min(deadline, t0 + self._rto), accept)
            if msg is not None:
                if k == 0:
                    self._rtt_sample(time.monotonic() - t0)
                return msg
            if time.monotonic() >= deadline:
                break
            self._backoff()
        raise TransferError(f"no answer from the vehicle to {what}")

    def _nack(self, msg: Any, mission_type: int, doing: str) -> MissionRejectedError:
        code = int(msg.type)
        name = mission_result_name(code)
        return MissionRejectedError(
            f"the vehicle refused the {mission_type_name(mission_type)} {doing}: {name}",
            name=name, code=code, mission_type=mission_type, retryable=code in RETRYABLE_ACKS,
        )  # fmt: skip

    def upload(self, items: Sequence[WireItem], mission_type: int, timeout: float) -> None:
        """Upload one list (seq 0..n-1, all of `mission_type`); raise on refusal or timeout."""
        ts, tc = self._target()
        t = int(mission_type)
        n = len(items)
        if n == 0:
            self.clear(t, timeout)
            return
        deadline = time.monotonic() + timeout
        highest = -1  # highest seq sent so far
        last: Any = _m.MAVLink_mission_count_message(ts, tc, n, t)

        def mine(msg: Any) -> bool:
            return (self._from_vehicle(msg)
                    and msg.get_type() in ("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK")
                    and int(msg.mission_type) == t)  # fmt: skip

        # no round-trip samples here: the vehicle paces an upload (its re-requests would count).
        # MISSION_REQUEST (not _INT) is answered with MISSION_ITEM_INT too, as MAVSDK does.
        retries = 0
        self._reset_rto()
        self._send(last)
        while True:
            msg = self._recv(min(deadline, time.monotonic() + self._rto), mine)
            if msg is None:
                retries += 1
                self._backoff()
                if time.monotonic() >= deadline or retries > self.max_retries:
                    waiting = ("the first item request" if highest < 0 else
                               "the final MISSION_ACK" if highest == n - 1 else
                               f"the request for item {highest + 1}")  # fmt: skip
                    raise TransferError(
                        f"{mission_type_name(t)} upload: no answer from the "
                        f"vehicle while waiting for {waiting}"
                    )
                self._send(last)  # the count again, or the last item sent
                continue
            if msg.get_type() == "MISSION_ACK":
                if int(msg.type) != _m.MAV_MISSION_ACCEPTED:
                    raise self._nack(msg, t, f"upload of {n} items")
                if highest == n - 1:
                    return
                continue  # a stale ACK (an earlier transfer's): not for this one
            seq = int(msg.seq)
            if not 0 <= seq < n:
                raise TransferError(
                    f"{mission_type_name(t)} upload: the vehicle asked for item {seq} of {n}"
                )
            if seq > highest:
                highest = seq
                retries = 0
                self._reset_rto()
            w = items[seq]
            last = _m.MAVLink_mission_item_int_message(ts, tc, *w.fields()[:-1], t)
            self._send(last)

    def download(self, mission_type: int, timeout: float) -> list[WireItem]:
        """Read one list back (MISSION_REQUEST_LIST, then each item by MISSION_REQUEST_INT)."""
        ts, tc = self._target()
        t = int(mission_type)
        deadline = time.monotonic() + timeout
        kind = mission_type_name(t)

        def answer(types: tuple[str, ...], seq: int | None = None) -> Callable[[Any], bool]:
            def ok(msg: Any) -> bool:
                if not self._from_vehicle(msg) or int(getattr(msg, "mission_type", -1)) != t:
                    return False
                name = msg.get_type()
                if name == "MISSION_ACK":
                    return int(msg.type) != _m.MAV_MISSION_ACCEPTED
                return name in types and (seq is None or int(msg.seq) == seq)

            return ok

        msg = self._exchange(
            lambda: self._send(_m.MAVLink_mission_request_list_message(ts, tc, t)),
            answer(("MISSION_COUNT",)), deadline, f"the {kind} list request",
        )  # fmt: skip
        if msg.get_type() == "MISSION_ACK":
            raise self._nack(msg, t, "download")
        count = int(msg.count)
        out: list[WireItem] = []
        for seq in range(count):
            msg = self._exchange(
                lambda seq=seq: self._send(_m.MAVLink_mission_request_int_message(ts, tc, seq, t)),
                answer(("MISSION_ITEM_INT", "MISSION_ITEM"), seq), deadline,
                f"the request for {kind} item {seq} of {count}",
            )  # fmt: skip
            if msg.get_type() == "MISSION_ACK":
                raise self._nack(msg, t, f"download (item {seq})")
            out.append(_wire_of(msg, t))
        self._send(_m.MAVLink_mission_ack_message(ts, tc, _m.MAV_MISSION_ACCEPTED, t))
        return out

    def clear(self, mission_type: int, timeout: float) -> None:
        """MISSION_CLEAR_ALL for one mission type, resent until the vehicle's MISSION_ACK."""
        ts, tc = self._target()
        t = int(mission_type)
        deadline = time.monotonic() + timeout

        def ack(msg: Any) -> bool:
            return (self._from_vehicle(msg) and msg.get_type() == "MISSION_ACK"
                    and int(msg.mission_type) == t)  # fmt: skip

        msg = self._exchange(
            lambda: self._send(_m.MAVLink_mission_clear_all_message(ts, tc, t)),
            ack, deadline, f"the {mission_type_name(t)} clear",
        )  # fmt: skip
        if int(msg.type) != _m.MAV_MISSION_ACCEPTED:
            raise self._nack(msg, t, "clear")


def _wire_of(msg: Any, mission_type: int) -> WireItem:
    if msg.get_type() == "MISSION_ITEM":  # float x/y: as MISSION_ITEM_INT would carry them
        from lamde_mission.items import MissionItem

        return to_wire(MissionItem(
            int(msg.seq), int(msg.command), int(msg.frame), int(msg.current),
            int(msg.autocontinue), msg.param1, msg.param2, msg.param3, msg.param4,
            msg.x, msg.y, msg.z, mission_type,
        ))  # fmt: skip
    return WireItem(
        int(msg.seq), int(msg.frame), int(msg.command), int(msg.current), int(msg.autocontinue),
        float(msg.param1), float(msg.param2), float(msg.param3), float(msg.param4),
        int(msg.x), int(msg.y), float(msg.z), int(msg.mission_type),
    )  # fmt: skip

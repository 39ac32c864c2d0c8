"""A mission uploader on pymavlink alone: the ground-station side of the MAVLink mission protocol.

`MavlinkClient` talks MAVLink 2 over UDP, TCP or a serial port (`connection.parse_connection`:
`udpin://HOST:PORT`, `udpout://HOST:PORT`, `tcp://HOST:PORT`, `serial:///dev/ttyUSB0:57600`) and
is a `MissionClient` for `transfer.upload_and_verify`.

Recovery is per message, as the mission protocol specifies (mavlink.io, "Mission Protocol",
timeouts and retries): MISSION_COUNT, MISSION_REQUEST_LIST, each MISSION_REQUEST_INT and
MISSION_CLEAR_ALL are resent after a silence, and so is the last item sent when the vehicle's
next request or its final MISSION_ACK does not come (a vehicle that already has it asks again or
ACKs again). The silence waited for adapts to the link as TCP's retransmission timeout does:
`item_timeout` until a round trip has been measured, then 4x the smoothed round trip (at least
`min_timeout`); after `backoff_after` silences in a row for the same message it grows 1.5x
per silence up to `max_timeout`. A transfer
gives up only after `timeout` seconds *without progress* (no new item), so a long list on a
lossy link is not cut off by a total time limit.

Talks only to the vehicle: after the first autopilot HEARTBEAT the vehicle's address (UDP/TCP
peer) and system/component ids are pinned; messages from another address, from other
system/component ids, or addressed to another system or component (a second ground station's
traffic, forged replies) are ignored and counted, and said under `log` (`--verbose`). Every
autopilot HEARTBEAT's source address is noted from the moment the link opens
(`claims.ClaimWatch`), and `connect` listens for `claims.HEARTBEAT_WATCH_S` in all before it
returns: the pinned ids heard from a second address, then or later in the session, end it with
`DuplicateVehicleError` naming both addresses (a fake that sent its HEARTBEATs first has
captured the link, or two vehicles share a system id, and nothing on an unsigned link tells
which is the vehicle).
"""

from __future__ import annotations

import collections
import time
from collections.abc import Callable, Sequence
from typing import Any

from pymavlink.dialects.v20 import common as mavlink2

from lamde_mission.vehicle.claims import (
    ClaimWatch,
    duplicate_error,
    is_vehicle_heartbeat,
)
from lamde_mission.vehicle.connection import Connection, Link, parse_connection
from lamde_mission.vehicle.transfer import (
    RETRYABLE_ACKS,
    MissionRejectedError,
    NoVehicleError,
    TransferError,
    VehicleError,
    VehicleInfo,
    no_vehicle_message,
)
from lamde_mission.vehicle.wire import (
    PacketCapture,
    WireItem,
    mission_result_name,
    mission_type_name,
    to_wire,
)
from planner_core.textio import counted

__all__ = ["MavlinkClient"]

_m = mavlink2

#: s between two PARAM_REQUEST_READs of one parameter (`MavlinkClient.read_param`)
PARAM_RESEND_S = 0.5

#: messages the mission protocol exchanges (what a second ground station's traffic consists of)
_MISSION_MSGS = frozenset({
    "MISSION_COUNT", "MISSION_REQUEST_LIST", "MISSION_REQUEST_INT", "MISSION_REQUEST",
    "MISSION_ITEM_INT", "MISSION_ITEM", "MISSION_ACK", "MISSION_CLEAR_ALL",
})  # fmt: skip


class MavlinkClient:
    """Ground-station side of the mission protocol (pymavlink messages, our sockets/port)."""

    name = "pymavlink"

    def __init__(
        self,
        connect: str | Connection = "udpin://0.0.0.0:14540",
        *,
        item_timeout: float = 0.25,
        min_timeout: float = 0.05,
        max_timeout: float = 1.5,
        max_retries: int | None = None,
        backoff_after: int = 8,
        system_id: int = 255,
        component_id: int = _m.MAV_COMP_ID_MISSIONPLANNER,
        log: Callable[[str], None] | None = None,
        progress: Callable[[str, int, int], None] | None = None,
        signing_key: bytes | None = None,
        heartbeat_watch: float | None = None,
        target_system: int | None = None,
    ) -> None:
        #: the vehicle's MAVLink system id to talk to (None: the first vehicle heard)
        self.target_system = None if target_system is None else int(target_system)
        try:
            self.endpoint: Connection = (
                connect if isinstance(connect, Connection) else parse_connection(connect)
            )
        except ValueError as exc:
            raise VehicleError(str(exc)) from None
        self.item_timeout = float(item_timeout)
        self.min_timeout = float(min_timeout)
        self.max_timeout = float(max_timeout)
        self.max_retries = None if max_retries is None else int(max_retries)
        self.backoff_after = int(backoff_after)
        self._srtt: float | None = None
        self._rto = self.item_timeout
        self.system_id = int(system_id)
        self.component_id = int(component_id)
        self.vehicle: VehicleInfo | None = None
        self.log = log or (lambda _s: None)
        self.progress = progress
        #: (reason, source) -> count of messages ignored (`ignored_lines` says them)
        self.ignored: collections.Counter[tuple[str, str]] = collections.Counter()
        self._mav = _m.MAVLink(
            PacketCapture(), srcSystem=self.system_id, srcComponent=self.component_id
        )
        self._mav.robust_parsing = True
        #: MAVLink 2 signing (`signing.enable_signing`): everything sent is signed, and an
        #: unsigned or wrongly signed message is dropped by the parser and counted
        self.signed = signing_key is not None
        if signing_key is not None:
            from lamde_mission.vehicle.signing import enable_signing

            enable_signing(self._mav, signing_key)
        self._pending: collections.deque[Any] = collections.deque()
        self._vehicle_addr: tuple[str, int] | None = None
        self._next_heartbeat = 0.0
        #: whether a message that changes the vehicle (a count, a clear) has been sent
        self.sent = False
        try:
            self._link: Link | None = Link(self.endpoint)
        except OSError as exc:
            raise VehicleError(f"cannot open {self.endpoint}: {exc.strerror or exc}") from None
        #: every autopilot HEARTBEAT's source address, from the moment the link is open
        self.watch = ClaimWatch(heartbeat_watch)

    # ------------------------------------------------------------------ life cycle

    def close(self) -> None:
        """Close the link (idempotent)."""
        if self._link is not None:
            self._link.close()
            self._link = None

    def __enter__(self) -> MavlinkClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ transport

    def _send(self, msg: Any) -> None:
        if self._link is None:
            raise TransferError("the connection is closed")
        self._mav.send(msg)
        try:
            self._link.send(self._mav.file.buf)
        except OSError as exc:
            raise TransferError(f"cannot send to {self.endpoint} ({exc})") from None

    def _heartbeat_if_due(self) -> None:
        now = time.monotonic()
        if self._link is not None and now >= self._next_heartbeat:
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

    def _backoff(self, silences: int) -> None:
        """After the `silences`-th silence in a row for one message: the same wait for the first
        `backoff_after`, then 1.5x each time up to `max_timeout`. On a lossy radio a lost
        message says nothing about congestion, and with loss p both ways a growing wait costs
        sum_k (1-(1-p)^2)^k * growth^k per item, which diverges at 40 % loss with doubling;
        many silences in a row, though, say the round trip was underestimated."""
        if silences >= self.backoff_after:
            self._rto = min(1.5 * self._rto, self.max_timeout)

    def _ignore(self, reason: str, msg: Any) -> None:
        addr = getattr(msg, "_lamde_addr", None)
        where = f"{addr[0]}:{addr[1]}" if addr else "the link"
        src = (f"{msg.get_type()} from system {msg.get_srcSystem()} component "
               f"{msg.get_srcComponent()} at {where}")  # fmt: skip
        key = (reason, src)
        if key not in self.ignored:
            self.log(f"ignored {src}: {reason}")
        self.ignored[key] += 1

    def ignored_lines(self) -> list[str]:
        """One line per (reason, sender) of what was ignored, with counts.

        Returns:
            "ignored N x SENDER: REASON" lines, in the order first ignored.
        """
        return [f"ignored {n} x {src}: {reason}" for (reason, src), n in self.ignored.items()]

    def _from_vehicle(self, msg: Any) -> bool:
        """Is `msg` the pinned vehicle's, addressed to us (or broadcast)? Says why if not."""
        v = self.vehicle
        if v is None:
            return False
        addr = getattr(msg, "_lamde_addr", None)
        if self._vehicle_addr is not None and addr is not None and addr != self._vehicle_addr:
            self._ignore(f"not the vehicle's address "
                         f"{self._vehicle_addr[0]}:{self._vehicle_addr[1]}", msg)  # fmt: skip
            return False
        if (msg.get_srcSystem(), msg.get_srcComponent()) != (v.system_id, v.component_id):
            if msg.get_type() in _MISSION_MSGS:
                self._ignore(f"not the vehicle (system {v.system_id} component "
                             f"{v.component_id})", msg)  # fmt: skip
            return False
        ts = getattr(msg, "target_system", 0)
        tc = getattr(msg, "target_component", 0)
        if ts not in (0, self.system_id) or tc not in (0, self.component_id):
            self._ignore(f"addressed to system {ts} component {tc}, not to us", msg)
            return False
        return True

    def _recv(self, until: float, accept: Callable[[Any], bool]) -> Any | None:
        """The first message that `accept`s before `until` (monotonic), else None."""
        while True:
            while self._pending:
                msg = self._pending.popleft()
                if accept(msg):
                    return msg
            self._heartbeat_if_due()
            left = until - time.monotonic()
            if left <= 0 or self._link is None:
                return None
            for data, addr in self._link.recv(min(left, 0.2)):
                try:
                    msgs = self._mav.parse_buffer(data) or []
                except Exception:
                    continue
                for msg in msgs:
                    if msg.get_type() == "BAD_DATA":
                        if self.signed and "signature" in str(getattr(msg, "reason", "")):
                            key = ("unsigned or wrongly signed (--signing-key)",
                                   f"a message at {addr[0]}:{addr[1]}" if addr else "the link")
                            if key not in self.ignored:
                                self.log(f"ignored {key[1]}: {key[0]}")
                            self.ignored[key] += 1
                        continue
                    msg._lamde_addr = addr
                    if self.watch.note(msg, addr):
                        self._check_claim()
                    self._pending.append(msg)

    def _check_claim(self) -> None:
        """DuplicateVehicleError when an autopilot HEARTBEAT with the pinned vehicle's ids has
        come from another address than the pinned one (before the pin or after)."""
        v, pinned = self.vehicle, self._vehicle_addr
        if v is None or pinned is None:
            return
        ids = (v.system_id, v.component_id)
        other = self.watch.conflict(ids, pinned)
        if other is not None:
            raise duplicate_error(ids, pinned, other, sent=self.sent)

    # ------------------------------------------------------------------ connect

    def connect(self, timeout: float) -> VehicleInfo:
        """Wait up to `timeout` s for an autopilot's HEARTBEAT (component 1).

        Pins the vehicle: its address and its system/component ids; from here on nothing else
        is listened to or answered. Then listens for the rest of the HEARTBEAT watch.

        Args:
            timeout: seconds to wait for the HEARTBEAT (of `target_system`, when set).

        Returns:
            The pinned vehicle.

        Raises:
            NoVehicleError: no such HEARTBEAT within `timeout`.
            DuplicateVehicleError: another address claims the vehicle's ids (`claims`).
        """
        deadline = time.monotonic() + timeout
        want = self.target_system

        def wanted(msg: Any) -> bool:
            return is_vehicle_heartbeat(msg) and (want is None or msg.get_srcSystem() == want)

        hb = self._recv(deadline, wanted)
        if hb is None:
            heard = self.watch.heard_systems()
            bad = sum(n for (why, _), n in self.ignored.items() if "signed" in why)
            raise NoVehicleError(no_vehicle_message(self.endpoint, timeout, want, heard, bad))
        addr = getattr(hb, "_lamde_addr", None)
        if self._link is not None and self.endpoint.scheme == "udpin" and addr is not None:
            self._link.peer = addr
            self._next_heartbeat = 0.0
        self._vehicle_addr = addr
        self.vehicle = VehicleInfo.from_heartbeat(hb)
        if addr is not None:
            self.log(f"pinned the vehicle: system {self.vehicle.system_id} component "
                     f"{self.vehicle.component_id} at {addr[0]}:{addr[1]}")  # fmt: skip
        self._heartbeat_if_due()
        self._check_claim()  # heard before the pin
        # the rest of the watch: a second autopilot with these ids raises in `_recv`
        self._recv(self.watch.ends_at(), lambda _msg: False)
        return self.vehicle

    def read_param(self, name: str, timeout: float) -> float | None:
        """One parameter of the pinned vehicle, by name (PARAM_REQUEST_READ, answered by
        PARAM_VALUE; the MAVLink parameter protocol), asked again every `PARAM_RESEND_S`.

        Args:
            name: the parameter's id, at most 16 characters (e.g. "MPC_XY_VEL_MAX").
            timeout: seconds to wait for the answer, > 0.

        Returns:
            Its value (float), or None when the vehicle does not answer in `timeout` s (no
            such parameter: autopilots answer nothing).

        Raises:
            TransferError: not connected.
        """
        ts, tc = self._target()
        deadline = time.monotonic() + timeout
        key = name.encode()[:16]

        def answer(msg: Any) -> bool:
            return (msg.get_type() == "PARAM_VALUE" and self._from_vehicle(msg)
                    and str(msg.param_id).rstrip("\x00") == name)  # fmt: skip

        while True:
            self._send(self._mav.param_request_read_encode(ts, tc, key, -1))
            msg = self._recv(min(deadline, time.monotonic() + PARAM_RESEND_S), answer)
            if msg is not None:
                return float(msg.param_value)
            if time.monotonic() >= deadline:
                return None

    def _target(self) -> tuple[int, int]:
        if self.vehicle is None:
            raise TransferError("not connected (call connect first)")
        return self.vehicle.system_id, self.vehicle.component_id

    def _progress(self, what: str, done: int, total: int) -> None:
        if self.progress is not None:
            self.progress(what, done, total)

    # ------------------------------------------------------------------ the protocol

    def _exchange(
        self,
        send: Callable[[], None],
        accept: Callable[[Any], bool],
        timeout: float,
        what: str,
    ) -> Any:
        """Send, wait for an accepted answer, resend after a silence; TransferError after
        `timeout` s without one (or `max_retries` resends).

        The wait grows only after many silences for this message (`_backoff`): on a lossy
        radio a lost message says nothing about the next one (no congestion to back off from).
        """
        self._reset_rto()
        deadline = time.monotonic() + timeout
        k = 0
        while True:
            t0 = time.monotonic()
            send()
            msg = self._recv(min(deadline, t0 + self._rto), accept)
            if msg is not None:
                if k == 0:
                    self._rtt_sample(time.monotonic() - t0)
                return msg
            k += 1
            if time.monotonic() >= deadline or (
                self.max_retries is not None and k > self.max_retries
            ):
                break
            self._backoff(k)
        raise TransferError(f"no answer from the vehicle to {what} "
                            f"({k} tries in {timeout:.3g} s)")  # fmt: skip

    def _nack(self, msg: Any, mission_type: int, doing: str) -> MissionRejectedError:
        code = int(msg.type)
        name = mission_result_name(code)
        return MissionRejectedError(
            f"the vehicle refused the {mission_type_name(mission_type)} {doing}: {name}",
            name=name, code=code, mission_type=mission_type, retryable=code in RETRYABLE_ACKS,
        )  # fmt: skip

    def upload(self, items: Sequence[WireItem], mission_type: int, timeout: float) -> None:
        """Upload one list (seq 0..n-1, all of `mission_type`); an empty list is a `clear`.

        Args:
            items: the list (`wire_mission`).
            mission_type: its MAV_MISSION_TYPE.
            timeout: seconds without progress (no new item requested, no final ACK).

        Returns:
            None, once the vehicle's MISSION_ACK accepts the whole list.

        Raises:
            MissionRejectedError: the vehicle refused (a MISSION_ACK with an error code).
            TransferError: not connected, `timeout` s without progress (`unanswered` when the
                vehicle answered nothing), the final ACK lost (the vehicle answered the
                resent last item with MAV_MISSION_ERROR), or a request for an item out of
                range.
            DuplicateVehicleError: another address claims the vehicle's ids.
        """
        ts, tc = self._target()
        t = int(mission_type)
        n = len(items)
        if n == 0:
            self.clear(t, timeout)
            return
        kind = mission_type_name(t)
        deadline = time.monotonic() + timeout
        highest = -1  # highest seq sent so far
        last: Any = _m.MAVLink_mission_count_message(ts, tc, n, t)
        self.sent = True

        def mine(msg: Any) -> bool:
            return (msg.get_type() in ("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK")
                    and self._from_vehicle(msg)
                    and int(msg.mission_type) == t)  # fmt: skip

        # round-trip samples (Karn): only from a message sent once answered by the request for
        # the next item (a vehicle's timer-driven re-request would overstate it, never understate)
        # MISSION_REQUEST (not _INT) is answered with MISSION_ITEM_INT too, as MAVSDK does.
        retries = 0
        resends = resends_crossed = 0
        answered = False  # anything of this transfer heard from the vehicle
        sent_at: float | None = time.monotonic()
        self._reset_rto()
        self._send(last)
        self._progress(f"{kind} upload", 0, n)
        while True:
            msg = self._recv(min(deadline, time.monotonic() + self._rto), mine)
            if msg is None:
                retries += 1
                self._backoff(retries)
                if time.monotonic() >= deadline or (
                    self.max_retries is not None and retries > self.max_retries
                ):
                    waiting = ("the first item request" if highest < 0 else
                               "the final MISSION_ACK" if highest == n - 1 else
                               f"the request for item {highest + 1}")  # fmt: skip
                    raise TransferError(
                        f"{kind} upload: no answer from the vehicle while waiting for "
                        f"{waiting} ({highest + 1} of {counted(n, 'item')} sent; {timeout:.3g} s "
                        "without progress)", unanswered=not answered,
                    )  # fmt: skip
                resends += 1
                sent_at = None
                self._send(last)  # the count again, or the last item sent
                continue
            answered = True
            if msg.get_type() == "MISSION_ACK":
                code = int(msg.type)
                if code == _m.MAV_MISSION_INVALID_SEQUENCE and highest < n - 1:
                    # ArduPilot's answer to an item out of turn (our resend crossed its next
                    # request); it keeps the transfer and asks again
                    resends_crossed += 1
                    continue
                if code == _m.MAV_MISSION_ERROR and highest == n - 1 and sent_at is None:
                    # the last item resent after a silence, answered as by ArduPilot, which has
                    # finished the transfer (its ACK was what got lost): the read-back decides
                    raise TransferError(
                        f"{kind} upload: the final MISSION_ACK was lost; the vehicle answered "
                        "the resent last item with MAV_MISSION_ERROR (no transfer in progress)"
                    )
                if code != _m.MAV_MISSION_ACCEPTED:
                    raise self._nack(msg, t, f"upload of {counted(n, 'item')}")
                if highest == n - 1:
                    self._progress(f"{kind} upload", n, n)
                    if resends:
                        self.log(f"{kind} upload: {resends} messages resent after a silence")
                    if resends_crossed:
                        self.log(f"{kind} upload: {resends_crossed} resent items came out of "
                                 "turn (MAV_MISSION_INVALID_SEQUENCE; the vehicle asked again)")
                    return
                continue  # a stale ACK (an earlier transfer's): not for this one
            seq = int(msg.seq)
            if not 0 <= seq < n:
                raise TransferError(f"{kind} upload: the vehicle asked for item {seq} of {n}")
            if seq > highest:
                if seq == highest + 1 and sent_at is not None:
                    self._rtt_sample(time.monotonic() - sent_at)
                highest = seq
                retries = 0
                deadline = time.monotonic() + timeout
                self._reset_rto()
                self._progress(f"{kind} upload", seq, n)
                sent_at = time.monotonic()
            else:
                sent_at = None  # a re-request: the item is sent again
            w = items[seq]
            last = _m.MAVLink_mission_item_int_message(ts, tc, *w.fields()[:-1], t)
            self._send(last)

    def download(self, mission_type: int, timeout: float) -> list[WireItem]:
        """Read one list back (MISSION_REQUEST_LIST, then each item by MISSION_REQUEST_INT).

        Args:
            mission_type: its MAV_MISSION_TYPE.
            timeout: seconds without an answer per request.

        Returns:
            The items the vehicle holds, in seq order (a MISSION_ITEM's float x/y as
            MISSION_ITEM_INT would carry them).

        Raises:
            MissionRejectedError: the vehicle answered with an error MISSION_ACK.
            TransferError: not connected, or no answer within `timeout`.
            DuplicateVehicleError: another address claims the vehicle's ids.
        """
        ts, tc = self._target()
        t = int(mission_type)
        kind = mission_type_name(t)

        def answer(types: tuple[str, ...], seq: int | None = None) -> Callable[[Any], bool]:
            def ok(msg: Any) -> bool:
                name = msg.get_type()
                if name not in types and name != "MISSION_ACK":
                    return False
                if not self._from_vehicle(msg) or int(getattr(msg, "mission_type", -1)) != t:
                    return False
                if name == "MISSION_ACK":
                    return int(msg.type) != _m.MAV_MISSION_ACCEPTED
                return name in types and (seq is None or int(msg.seq) == seq)

            return ok

        msg = self._exchange(
            lambda: self._send(_m.MAVLink_mission_request_list_message(ts, tc, t)),
            answer(("MISSION_COUNT",)), timeout, f"the {kind} list request",
        )  # fmt: skip
        if msg.get_type() == "MISSION_ACK":
            raise self._nack(msg, t, "download")
        count = int(msg.count)
        out: list[WireItem] = []
        self._progress(f"{kind} download", 0, count)
        for seq in range(count):
            msg = self._exchange(
                lambda seq=seq: self._send(_m.MAVLink_mission_request_int_message(ts, tc, seq, t)),
                answer(("MISSION_ITEM_INT", "MISSION_ITEM"), seq), timeout,
                f"the request for {kind} item {seq} of {count}",
            )  # fmt: skip
            if msg.get_type() == "MISSION_ACK":
                raise self._nack(msg, t, f"download (item {seq})")
            out.append(_wire_of(msg, t))
            self._progress(f"{kind} download", seq + 1, count)
        self._send(_m.MAVLink_mission_ack_message(ts, tc, _m.MAV_MISSION_ACCEPTED, t))
        return out

    def clear(self, mission_type: int, timeout: float) -> None:
        """MISSION_CLEAR_ALL for one mission type, resent until the vehicle's MISSION_ACK.

        Args:
            mission_type: its MAV_MISSION_TYPE.
            timeout: seconds without an answer.

        Returns:
            None, once the vehicle's MISSION_ACK accepts the clear.

        Raises:
            MissionRejectedError: the MISSION_ACK is not MAV_MISSION_ACCEPTED.
            TransferError: not connected, or no answer within `timeout`.
            DuplicateVehicleError: another address claims the vehicle's ids.
        """
        ts, tc = self._target()
        t = int(mission_type)

        def ack(msg: Any) -> bool:
            return (msg.get_type() == "MISSION_ACK" and self._from_vehicle(msg)
                    and int(msg.mission_type) == t)  # fmt: skip

        self.sent = True
        msg = self._exchange(
            lambda: self._send(_m.MAVLink_mission_clear_all_message(ts, tc, t)),
            ack, timeout, f"the {mission_type_name(t)} clear",
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

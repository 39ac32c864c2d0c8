"""MAVSDK's way to the vehicle: a local relay that pins the vehicle, watches who claims it, and
signs for MAVSDK when the link is signed.

MAVSDK follows a system id wherever it is heard: with two autopilots claiming system 1 from two
addresses it talks to both as one and may upload to either. MAVSDK-Python 4 also has no signing
API. So `MavsdkClient` never opens the vehicle's link itself: `VehicleRelay` holds it (any
scheme of `connection.Link`) and gives MAVSDK a UDP socket on 127.0.0.1 (`url`, MAVSDK's
`udpout://127.0.0.1:PORT`). The relay

- pins the vehicle at the address of the first autopilot HEARTBEAT (component 1; of system
  `system_id` when given), as the pymavlink client does, and passes MAVSDK only that
  address's messages (and only that system's, with `system_id`: several vehicles on one
  link); the rest are counted;
- notes every autopilot HEARTBEAT's source (`claims.ClaimWatch`): once the vehicle's ids are
  heard from a second address it passes nothing more either way and sets `conflict`, which
  `MavsdkClient` turns into `DuplicateVehicleError`;
- counts the vehicle's answers in the mission protocol that it passes to MAVSDK
  (MISSION_REQUEST_INT, MISSION_REQUEST, MISSION_ACK; `mission_answers`), by mission type:
  MAVSDK's TIMEOUT does not say whether the vehicle answered an upload at all, this count does;
- with a signing key, passes on only messages signed with it (checked by pymavlink; the rest
  are dropped and counted in `dropped`) and sends what MAVSDK sends re-packed and signed, with
  MAVSDK's own system/component ids and sequence numbers. Without a key MAVSDK's bytes go out
  as they are.
"""

from __future__ import annotations

import contextlib
import select
import socket
import threading
from typing import Any

from pymavlink.dialects.v20 import common as mavlink2

from lamde_mission.vehicle.claims import ClaimWatch, is_vehicle_heartbeat
from lamde_mission.vehicle.connection import Connection, Link
from lamde_mission.vehicle.signing import (
    carries_signature,
    enable_signing,
    is_signature_failure,
)

__all__ = ["VehicleRelay"]

Address = tuple[str, int]

#: the vehicle's messages that answer a ground station's mission upload (a request for an item,
#: or the ACK that ends or refuses the list)
_MISSION_ANSWERS = frozenset({"MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"})


class VehicleRelay:
    """A relay between MAVSDK (on 127.0.0.1) and the vehicle's link, in a background thread.

    Args:
        conn: the vehicle's connection (`connection.parse_connection`).
        signing_key: the 32-byte MAVLink 2 signing key, or None for an unsigned link.
        heartbeat_watch: seconds of the watch before the first send (`claims.ClaimWatch`;
            None: `claims.HEARTBEAT_WATCH_S`).

    Raises:
        OSError: the vehicle's link or the local socket cannot be opened (nothing left open).
    """

    def __init__(
        self,
        conn: Connection,
        signing_key: bytes | None = None,
        *,
        heartbeat_watch: float | None = None,
        system_id: int | None = None,
    ) -> None:
        #: the vehicle's system id (None: the first vehicle heard); on a link several vehicles
        #: share, MAVSDK is passed this system's messages only: one MAVSDK per vehicle (MAVSDK
        #: 4.1 itself would list every system of the link; the older mavsdk_server serves
        #: one, and its maintainers advise demultiplexing: mavlink/MAVSDK-Python issue 685)
        self.system_id = None if system_id is None else int(system_id)
        #: messages dropped because they came from another system than `system_id`
        self.other_systems = 0
        #: parses the vehicle's bytes (and checks their signatures on a signed link)
        self._check = mavlink2.MAVLink(None)
        self._check.robust_parsing = True
        self._sign: Any = None
        self._plain: Any = None
        if signing_key is not None:
            enable_signing(self._check, signing_key)
            self._sign = mavlink2.MAVLink(None)  # signs MAVSDK's messages
            enable_signing(self._sign, signing_key, link_id=2)
            self._plain = mavlink2.MAVLink(None)  # reads MAVSDK's (unsigned) bytes
            self._plain.robust_parsing = True
        self.link = Link(conn)
        try:
            self._gcs = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            self._gcs.bind(("127.0.0.1", 0))
            self._gcs.setblocking(False)
        except OSError:
            self.link.close()
            raise
        self.watch = ClaimWatch(heartbeat_watch)
        self._gcs_addr: Address | None = None
        self.url = f"udpout://127.0.0.1:{self._gcs.getsockname()[1]}"
        #: messages dropped for a missing or wrong signature
        self.dropped = 0
        #: messages dropped because they came from another address than the vehicle's
        self.foreign = 0
        #: the vehicle: its (system, component) and address (None on a serial link), once heard
        self.vehicle_ids: tuple[int, int] | None = None
        #: whether the pinned vehicle's HEARTBEAT carried a MAVLink 2 signature
        self.vehicle_signed = False
        #: the HEARTBEAT the vehicle was pinned by (set before any message reaches MAVSDK):
        #: `MavsdkClient` names the vehicle from it as the pymavlink client does
        self.vehicle_heartbeat: Any = None
        self.vehicle_addr: Address | None = None
        self._pinned = False
        #: the second address claiming the vehicle's ids, once heard (the relay then passes
        #: nothing more)
        self.conflict: Address | None = None
        #: MISSION_REQUEST_INT / MISSION_REQUEST / MISSION_ACK passed from the vehicle to
        #: MAVSDK, by MAV_MISSION_TYPE (written by the relay's thread only)
        self._answers: dict[int, int] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="vehicle-relay", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            waitables = [*self.link.waitables(), self._gcs]
            try:
                ready, _, _ = select.select(waitables, [], [], 0.05)
            except (OSError, ValueError):
                return
            if not ready:
                continue
            if any(w is not self._gcs for w in ready):
                for data, addr in self.link.recv(0.0):
                    self._from_vehicle(data, addr)
            if self._gcs in ready:
                self._drain_gcs()

    def _drain_gcs(self) -> None:
        for _ in range(64):
            try:
                data, addr = self._gcs.recvfrom(65536)
            except (BlockingIOError, InterruptedError, OSError):
                return
            self._gcs_addr = addr
            self._from_gcs(data)

    def _from_vehicle(self, data: bytes, addr: Address | None) -> None:
        for msg in self._check.parse_buffer(data) or []:
            if msg.get_type() == "BAD_DATA":
                self.dropped += is_signature_failure(msg)
                continue
            new_claim = self.watch.note(msg, addr)
            if (
                not self._pinned
                and is_vehicle_heartbeat(msg)
                and (self.system_id is None or msg.get_srcSystem() == self.system_id)
            ):
                self._pinned = True
                self.vehicle_ids = (msg.get_srcSystem(), msg.get_srcComponent())
                self.vehicle_signed = carries_signature(msg)
                self.vehicle_heartbeat = msg
                self.vehicle_addr = addr
                if self.link.conn.scheme == "udpin" and addr is not None:
                    self.link.peer = addr
                new_claim = True
            if new_claim and self.conflict is None and self.vehicle_ids is not None:
                self.conflict = self.watch.conflict(self.vehicle_ids, self.vehicle_addr)
            if self.conflict is not None or not self._pinned:
                continue
            if addr != self.vehicle_addr:
                self.foreign += 1
                continue
            if self.system_id is not None and msg.get_srcSystem() != self.system_id:
                self.other_systems += 1
                continue
            if msg.get_type() in _MISSION_ANSWERS:
                t = int(getattr(msg, "mission_type", 0) or 0)
                self._answers[t] = self._answers.get(t, 0) + 1
            if self._gcs_addr is not None:
                with contextlib.suppress(OSError):
                    self._gcs.sendto(bytes(msg.get_msgbuf()), self._gcs_addr)

    def _from_gcs(self, data: bytes) -> None:
        if self.conflict is not None:
            return
        if self.link.peer is None and self.link.conn.scheme in ("udpin", "tcpin"):
            return  # nobody to send to yet
        if self._sign is None:
            with contextlib.suppress(OSError, ValueError):
                self.link.send(data)
            return
        for msg in self._plain.parse_buffer(data) or []:
            if msg.get_type() == "BAD_DATA":
                continue
            self._sign.srcSystem = msg.get_srcSystem()
            self._sign.srcComponent = msg.get_srcComponent()
            self._sign.seq = msg.get_seq()
            with contextlib.suppress(OSError, ValueError):
                self.link.send(msg.pack(self._sign))

    def mission_answers(self, mission_type: int) -> int:
        """How many of the vehicle's mission-protocol answers (an item request or a
        MISSION_ACK) of `mission_type` the relay has passed to MAVSDK so far.

        Args:
            mission_type: MAV_MISSION_TYPE (mission, fence, rally).

        Returns:
            The count since the relay opened; compare two readings around a transfer.
        """
        return self._answers.get(int(mission_type), 0)

    def ignored_lines(self) -> list[str]:
        """One line per kind of message the relay kept from MAVSDK, with counts.

        Returns:
            "ignored N x ..." lines for wrongly signed messages, messages from another
            address than the vehicle's and from another system on its link (those counted).
        """
        out = []
        if self.dropped:
            out.append(f"ignored {self.dropped} x a message: unsigned or wrongly signed "
                       "(--signing-key)")  # fmt: skip
        if self.foreign and self.vehicle_addr is not None:
            a = self.vehicle_addr
            out.append(f"ignored {self.foreign} x a message from another address than the "
                       f"vehicle's {a[0]}:{a[1]}")  # fmt: skip
        if self.other_systems:
            out.append(f"ignored {self.other_systems} x a message from another system than the "
                       f"vehicle's (system {self.system_id}) on its link")  # fmt: skip
        return out

    def close(self) -> None:
        """Stop the relay and close both sockets (idempotent)."""
        self._stop.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(2.0)
        self.link.close()
        self._gcs.close()

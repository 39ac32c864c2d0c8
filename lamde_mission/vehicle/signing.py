"""MAVLink 2 message signing (mavlink.io, "Message Signing"): the key and the link state.

A signed link appends to every message a 6-byte signature (the first 48 bits of
SHA-256(secret key + header + payload + CRC + link id + timestamp)) and a timestamp in 10 us
units since 2015-01-01 that never goes back per (link id, system, component); a receiver with
the key drops an unsigned message, a wrong signature or a replayed timestamp. pymavlink does
the arithmetic (`MAVLink.signing`: `secret_key`, `sign_outgoing`, `link_id`, `timestamp`,
`allow_unsigned_callback`, as `mavutil.mavfile.setup_signing` sets them); this module gives
both ends (our pymavlink client and the mock vehicle) one way to set it up.

The key: 64 hexadecimal digits are the 32-byte key itself; any other text is a passphrase whose
SHA-256 is the key (MAVProxy's `signing setup PASSPHRASE` and QGroundControl derive it so).
"""

from __future__ import annotations

import contextlib
import hashlib
import re
import time
from typing import Any

__all__ = ["KEY_BYTES", "SigningRelay", "enable_signing", "is_signature_failure", "signing_key"]

#: bytes of a MAVLink 2 signing key
KEY_BYTES = 32
#: seconds from the Unix epoch to MAVLink's signing epoch, 2015-01-01 00:00:00 UTC
_EPOCH_2015 = 1_420_070_400
_HEX_KEY = re.compile(r"[0-9a-fA-F]{64}")


def signing_key(text: str) -> bytes:
    """The 32-byte signing key `text` names.

    Args:
        text: 64 hexadecimal digits (the key itself) or a passphrase (hashed with SHA-256).

    Returns:
        The key.

    Raises:
        ValueError: `text` is empty or only whitespace.
    """
    if not isinstance(text, str) or not text.strip():
        raise ValueError("the signing key is empty (give 64 hex digits or a passphrase)")
    if _HEX_KEY.fullmatch(text):
        return bytes.fromhex(text)
    return hashlib.sha256(text.encode("utf-8")).digest()


def enable_signing(mav: Any, key: bytes, *, link_id: int = 0) -> None:
    """Sign everything `mav` (a pymavlink `MAVLink` object) sends with `key`, and accept only
    messages signed with it: an unsigned or wrongly signed one is refused by the parser
    (BAD_DATA "Invalid signature" under robust parsing), as is a replayed timestamp.

    Args:
        mav: the pymavlink MAVLink object of one end of the link.
        key: the 32-byte key (`signing_key`).
        link_id: this end's link id (0-255), part of the replay protection.

    Raises:
        ValueError: `key` is not 32 bytes or `link_id` is outside 0-255.
    """
    if not isinstance(key, bytes | bytearray) or len(key) != KEY_BYTES:
        raise ValueError(f"a MAVLink signing key is {KEY_BYTES} bytes")
    if not 0 <= int(link_id) <= 255:
        raise ValueError(f"link_id must be in 0..255, got {link_id}")
    mav.signing.secret_key = bytes(key)
    mav.signing.sign_outgoing = True
    mav.signing.allow_unsigned_callback = None  # nothing unsigned gets through
    mav.signing.link_id = int(link_id)
    mav.signing.timestamp = int(max(time.time() - _EPOCH_2015, 0.0) * 100_000)


def is_signature_failure(msg: Any) -> bool:
    """Whether a parsed message is pymavlink's BAD_DATA for a missing or wrong signature."""
    return msg.get_type() == "BAD_DATA" and "signature" in str(getattr(msg, "reason", "")).lower()


class SigningRelay:
    """A signing proxy for a ground station without signing (MAVSDK-Python 4): it holds the
    vehicle's link (`connection.Link`, any scheme) and a UDP socket on 127.0.0.1 for the
    ground station (`url`, e.g. MAVSDK's `udpout://127.0.0.1:PORT`). From the vehicle it
    passes on only messages signed with `key` (checked by pymavlink; the rest are dropped and
    counted in `dropped`); what the ground station sends goes to the vehicle re-packed and
    signed, with the ground station's own system/component ids and sequence numbers. A `udpin`
    link is pinned to the first address that sends a correctly signed message.
    """

    def __init__(self, conn: Any, key: bytes) -> None:
        import socket
        import threading

        from pymavlink.dialects.v20 import common as mavlink2

        from lamde_mission.vehicle.connection import Link

        self._check = mavlink2.MAVLink(None)  # checks the vehicle's signatures
        self._check.robust_parsing = True
        enable_signing(self._check, key)
        self._sign = mavlink2.MAVLink(None)  # signs the ground station's messages
        enable_signing(self._sign, key, link_id=2)
        self._plain = mavlink2.MAVLink(None)  # reads the ground station's (unsigned) bytes
        self._plain.robust_parsing = True
        self.link = Link(conn)
        self._gcs = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._gcs.bind(("127.0.0.1", 0))
        self._gcs.setblocking(False)
        self._gcs_addr: tuple[str, int] | None = None
        self.url = f"udpout://127.0.0.1:{self._gcs.getsockname()[1]}"
        self.dropped = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="signing-relay", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        import select

        while not self._stop.is_set():
            for data, addr in self.link.recv(0.02):
                self._from_vehicle(data, addr)
            try:
                ready, _, _ = select.select([self._gcs], [], [], 0.0)
            except (OSError, ValueError):
                return
            while ready:
                try:
                    data, addr = self._gcs.recvfrom(65536)
                except (BlockingIOError, InterruptedError, OSError):
                    break
                self._gcs_addr = addr
                self._from_gcs(data)

    def _from_vehicle(self, data: bytes, addr: tuple[str, int] | None) -> None:
        for msg in self._check.parse_buffer(data) or []:
            if msg.get_type() == "BAD_DATA":
                self.dropped += is_signature_failure(msg)
                continue
            if self.link.conn.scheme == "udpin" and self.link.peer is None and addr is not None:
                self.link.peer = addr
            if self._gcs_addr is not None:
                with contextlib.suppress(OSError):
                    self._gcs.sendto(bytes(msg.get_msgbuf()), self._gcs_addr)

    def _from_gcs(self, data: bytes) -> None:
        for msg in self._plain.parse_buffer(data) or []:
            if msg.get_type() == "BAD_DATA":
                continue
            self._sign.srcSystem = msg.get_srcSystem()
            self._sign.srcComponent = msg.get_srcComponent()
            self._sign.seq = msg.get_seq()
            buf = msg.pack(self._sign)
            if self.link.peer is None and self.link.conn.scheme in ("udpin", "tcpin"):
                continue  # nobody to send to yet
            with contextlib.suppress(OSError, ValueError):
                self.link.send(buf)

    def close(self) -> None:
        """Stop the relay and close both sockets (idempotent)."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(2.0)
        self.link.close()
        self._gcs.close()

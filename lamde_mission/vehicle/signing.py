"""MAVLink 2 message signing (mavlink.io, "Message Signing"): the key and the link state.

A signed link appends to every message a 6-byte signature (the first 48 bits of
SHA-256(secret key + header + payload + CRC + link id + timestamp)) and a timestamp in 10 us
units since 2015-01-01 that never goes back per (link id, system, component); a receiver with
the key drops an unsigned message, a wrong signature or a replayed timestamp. pymavlink does
the arithmetic (`MAVLink.signing`: `secret_key`, `sign_outgoing`, `link_id`, `timestamp`,
`allow_unsigned_callback`, as `mavutil.mavfile.setup_signing` sets them); this module gives
both ends (our pymavlink client and the mock vehicle) one way to set it up. MAVSDK-Python 4,
which cannot sign, talks through `relay.VehicleRelay`, which signs for it.

The key: 64 hexadecimal digits are the 32-byte key itself; any other text is a passphrase whose
SHA-256 is the key (MAVProxy's `signing setup PASSPHRASE` and QGroundControl derive it so).
"""

from __future__ import annotations

import hashlib
import re
import time
from typing import Any

__all__ = ["KEY_BYTES", "enable_signing", "is_signature_failure", "signing_key"]

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
    """Whether a parsed message is pymavlink's BAD_DATA for a missing or wrong signature.

    Args:
        msg: a parsed pymavlink message.

    Returns:
        True for BAD_DATA whose reason mentions "signature" (any case).
    """
    return msg.get_type() == "BAD_DATA" and "signature" in str(getattr(msg, "reason", "")).lower()


#: MAVLink 2's incompat flag of a signed message (the MAVLink 2 spec, "Message signing")
IFLAG_SIGNED = 0x01


def carries_signature(msg: Any) -> bool:
    """Whether a parsed MAVLink 2 message came with a signature block (its header's
    incompat flag), whatever the parser made of it: a parser without a key keeps signed
    messages and says nothing of their signature (pymavlink).

    Args:
        msg: a parsed pymavlink message.

    Returns:
        True when its header's incompat flags have `IFLAG_SIGNED` (False without a header).
    """
    header = getattr(msg, "_header", None)
    return bool(int(getattr(header, "incompat_flags", 0) or 0) & IFLAG_SIGNED)

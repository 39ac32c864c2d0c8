"""Mission items as MAVLink carries them (MISSION_ITEM_INT), and the read-back comparison.

Both uploaders and the mock vehicle speak in `WireItem`s, so "what went up" and "what came back"
are compared in one place, after the conversions MAVLink imposes:

- x/y (latitude/longitude) travel as int32: degrees x 1e7 in global frames (a read-back may
  differ from the file by the rounding, so they are compared with a tolerance of 1 unit =
  1e-7 degree); in MAV_FRAME_MISSION (DO commands) they are params 5/6 sent as plain integers,
  as MAVSDK's QGroundControl importer does; local frames use metres x 1e4. A NaN x/y ("not
  used") travels as INT32_MAX and reads back as NaN.
- param1..4 and z (altitude) travel as float32: compared as float32 values, NaN equal to NaN.
- seq, command, frame, autocontinue and mission_type must match exactly. `current` is not
  compared: uploads mark item 0 current (MAVSDK refuses a list without exactly one current
  item), and what a vehicle reports back for it is the vehicle's business.
"""

from __future__ import annotations

import math
import socket
from collections.abc import Sequence
from dataclasses import dataclass
from urllib.parse import urlsplit

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from lamde_mission.items import FRAME, MISSION_TYPE, MissionItem

__all__ = [
    "PacketCapture",
    "open_udp",
    "WireItem",
    "Difference",
    "Endpoint",
    "to_wire",
    "wire_mission",
    "from_wire",
    "compare_items",
    "parse_endpoint",
    "mission_result_name",
    "mission_result_code",
    "mission_type_name",
    "INT32_MAX",
]

INT32_MAX = 2**31 - 1
_INT32_MIN = -(2**31)

#: frames whose x/y are latitude/longitude (degrees x 1e7 on the wire)
GLOBAL_FRAMES = frozenset(
    {
        FRAME.GLOBAL,
        FRAME.GLOBAL_RELATIVE_ALT,
        FRAME.GLOBAL_INT,
        FRAME.GLOBAL_RELATIVE_ALT_INT,
        mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT,
        mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    }
)


def _xy_scale(frame: int) -> float:
    if frame in GLOBAL_FRAMES:
        return 1e7
    if frame == FRAME.MISSION:
        return 1.0
    return 1e4  # local frames: metres x 1e4 (MISSION_ITEM_INT)


def _f32(v: float) -> float:
    """`v` rounded to float32 (what MAVLink carries); OverflowError if it does not fit."""
    v = float(v)
    if math.isnan(v):
        return math.nan
    out = float(np.float32(v)) if abs(v) <= 3.4028234663852886e38 else math.inf
    if math.isinf(out) and not math.isinf(v):
        raise OverflowError(f"{v!r} does not fit in a float32")
    return out


@dataclass(frozen=True)
class WireItem:
    """One MISSION_ITEM_INT's fields (x, y int32; params and z float32 values)."""

    seq: int
    frame: int
    command: int
    current: int
    autocontinue: int
    param1: float
    param2: float
    param3: float
    param4: float
    x: int
    y: int
    z: float
    mission_type: int

    def fields(self) -> tuple:
        """The values in MISSION_ITEM_INT order (seq .. mission_type), for message packing.

        Returns:
            (seq, frame, command, current, autocontinue, param1..param4, x, y, z,
            mission_type).
        """
        return (
            self.seq, self.frame, self.command, self.current, self.autocontinue,
            self.param1, self.param2, self.param3, self.param4, self.x, self.y, self.z,
            self.mission_type,
        )  # fmt: skip


def _xy_to_int(v: float, frame: int, name: str, seq: int) -> int:
    v = float(v)
    if math.isnan(v):
        return INT32_MAX
    scale = _xy_scale(frame)
    i = int(round(v * scale)) if scale != 1.0 else int(v)
    if not _INT32_MIN <= i <= INT32_MAX:
        raise ValueError(f"item {seq}: {name} = {v!r} does not fit MAVLink's int32 (frame {frame})")
    return i


def to_wire(item: MissionItem, *, seq: int | None = None, current: int | None = None) -> WireItem:
    """`item` as MISSION_ITEM_INT carries it. Nothing is ever wrapped or truncated to fit.

    Args:
        item: the mission item.
        seq: the sequence number sent (default the item's).
        current: the `current` flag sent (default the item's).

    Returns:
        The `WireItem`: params and z rounded to float32, x/y as int32 (degrees x 1e7 in
        global frames, metres x 1e4 in local frames, plain in MAV_FRAME_MISSION; NaN as
        INT32_MAX).

    Raises:
        ValueError: naming the item and field, a value that does not fit MAVLink's type for
            it (`formats.ranges.check_mission_item`, whose MissionError is a ValueError:
            command uint16, frame/current/autocontinue uint8, params and z float32, x/y int32
            after scaling, latitude and longitude in range).
    """
    from lamde_mission.formats.ranges import check_mission_item

    s = int(item.seq if seq is None else seq)
    check_mission_item(item, lambda f: f"item {s}: {f}")
    frame = int(item.frame)
    try:
        p = [_f32(getattr(item, k)) for k in ("param1", "param2", "param3", "param4", "z")]
    except OverflowError as exc:
        raise ValueError(f"item {s}: {exc}") from None
    return WireItem(
        seq=s, frame=frame, command=int(item.command),
        current=int(item.current if current is None else current),
        autocontinue=int(item.autocontinue), param1=p[0], param2=p[1], param3=p[2], param4=p[3],
        x=_xy_to_int(item.x, frame, "x (latitude)", s),
        y=_xy_to_int(item.y, frame, "y (longitude)", s),
        z=p[4], mission_type=int(item.mission_type),
    )  # fmt: skip


def wire_mission(items: Sequence[MissionItem], mission_type: int | None = None) -> list[WireItem]:
    """The list to upload: seq renumbered 0..n-1, item 0 marked current, one mission type.

    Args:
        items: the items, in order.
        mission_type: the list's MAV_MISSION_TYPE, which every item must have; None: the
            items' own (one type).

    Returns:
        The `WireItem`s.

    Raises:
        ValueError: the items mix mission types (or differ from `mission_type`), or a value
            does not fit MAVLink's fields (`to_wire`).
    """
    out = [to_wire(it, seq=k, current=int(k == 0)) for k, it in enumerate(items)]
    types = {w.mission_type for w in out} | ({mission_type} if mission_type is not None else set())
    if len(types) > 1:
        names = ", ".join(mission_type_name(t) for t in sorted(types))
        raise ValueError(f"one upload holds one mission type, got {names}")
    return out


def from_wire(w: WireItem) -> MissionItem:
    """The MissionItem a WireItem stands for (x/y back in degrees for global frames).

    Args:
        w: the wire item.

    Returns:
        The `MissionItem`: x/y divided by the frame's scale (INT32_MAX as NaN), params and z
        as floats.
    """
    scale = _xy_scale(w.frame)

    def xy(i: int) -> float:
        return math.nan if i == INT32_MAX else (i / scale if scale != 1.0 else float(i))

    return MissionItem(
        seq=int(w.seq), command=int(w.command), frame=int(w.frame), current=int(w.current),
        autocontinue=int(w.autocontinue), param1=float(w.param1), param2=float(w.param2),
        param3=float(w.param3), param4=float(w.param4), x=xy(w.x), y=xy(w.y), z=float(w.z),
        mission_type=int(w.mission_type),
    )  # fmt: skip


# ----------------------------------------------------------------------------- comparison


@dataclass(frozen=True)
class Difference:
    """One way a read-back differs from what was sent: `index` None for the item count."""

    what: str  # "mission" | "fence" | "rally"
    index: int | None
    field: str
    sent: object
    got: object

    def __str__(self) -> str:
        if self.index is None:
            return f"{self.what}: sent {self.sent} items, read back {self.got}"
        return (
            f"{self.what} item {self.index}: {self.field} sent {self.sent!r}, "
            f"read back {self.got!r}"
        )


_INT_FIELDS = ("seq", "command", "frame", "autocontinue", "mission_type")
_FLOAT_FIELDS = ("param1", "param2", "param3", "param4", "z")


def _same_float(a: float, b: float) -> bool:
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return a == b


def _shown(w: WireItem, name: str) -> object:
    """A field in user units (degrees for lat/lon) for messages."""
    if name in ("x", "y"):
        return getattr(from_wire(w), name)
    return getattr(w, name)


def compare_items(
    sent: Sequence[WireItem | MissionItem],
    got: Sequence[WireItem | MissionItem],
    what: str = "mission",
    *,
    xy_tolerance: int = 1,
) -> list[Difference]:
    """Every difference between `sent` and `got`, item by item, after MAVLink's conversions.

    x/y may differ by `xy_tolerance` int units in global frames (1 = 1e-7 degree, the rounding
    of the int32 encoding); everything else must be equal (NaN equal to NaN; `current` ignored).

    Args:
        sent: the items sent (`MissionItem`s are converted with `to_wire`, seq = position).
        got: the items read back.
        what: "mission", "fence" or "rally", for the differences.
        xy_tolerance: int32 units x/y may differ by in global frames (0 elsewhere).

    Returns:
        The `Difference`s: the count first when the lengths differ, then per item pair (the
        shorter list's length) each differing field; empty when they match.

    Raises:
        ValueError: a `MissionItem` that does not fit MAVLink's fields (`to_wire`).
    """
    a = [w if isinstance(w, WireItem) else to_wire(w, seq=k) for k, w in enumerate(sent)]
    b = [w if isinstance(w, WireItem) else to_wire(w, seq=k) for k, w in enumerate(got)]
    diffs: list[Difference] = []
    if len(a) != len(b):
        diffs.append(Difference(what, None, "count", len(a), len(b)))
    for k, (s, g) in enumerate(zip(a, b, strict=False)):
        for name in _INT_FIELDS:
            if int(getattr(s, name)) != int(getattr(g, name)):
                diffs.append(Difference(what, k, name, getattr(s, name), getattr(g, name)))
        for name in _FLOAT_FIELDS:
            if not _same_float(getattr(s, name), getattr(g, name)):
                diffs.append(Difference(what, k, name, getattr(s, name), getattr(g, name)))
        tol = xy_tolerance if s.frame in GLOBAL_FRAMES else 0
        for name in ("x", "y"):
            i, j = getattr(s, name), getattr(g, name)
            nan_i, nan_j = i == INT32_MAX, j == INT32_MAX
            if nan_i != nan_j or abs(i - j) > tol:
                diffs.append(Difference(what, k, name, _shown(s, name), _shown(g, name)))
    return diffs


# ----------------------------------------------------------------------------- names


def mission_result_name(code: int) -> str:
    """MAV_MISSION_RESULT name of `code` (e.g. 4 -> "MAV_MISSION_NO_SPACE").

    Args:
        code: a MAV_MISSION_RESULT number.

    Returns:
        Its enum name, or "MAV_MISSION_RESULT <code>" for a number pymavlink lacks.
    """
    entry = mavlink2.enums["MAV_MISSION_RESULT"].get(int(code))
    return entry.name if entry is not None else f"MAV_MISSION_RESULT {code}"


_RESULTS = {
    c: e
    for c, e in mavlink2.enums["MAV_MISSION_RESULT"].items()
    if c != mavlink2.MAV_MISSION_RESULT_ENUM_END
}


def mission_result_code(value: int | str) -> int:
    """A MAV_MISSION_RESULT code from a number or a name ("NO_SPACE", "MAV_MISSION_NO_SPACE").

    Args:
        value: an int, a string of digits, or a name (case and surrounding spaces ignored;
            the MAV_MISSION_ prefix optional).

    Returns:
        The code.

    Raises:
        ValueError: an unknown code or name (the message lists the known names).
    """
    if isinstance(value, int) or (isinstance(value, str) and value.strip().isdigit()):
        code = int(value)
        if code in _RESULTS:
            return code
        raise ValueError(f"unknown MAV_MISSION_RESULT code {code}")
    name = value.strip().upper()
    if not name.startswith("MAV_MISSION_"):
        name = "MAV_MISSION_" + name
    for code, entry in _RESULTS.items():
        if entry.name == name:
            return int(code)
    known = ", ".join(e.name.removeprefix("MAV_MISSION_") for e in _RESULTS.values())
    raise ValueError(f"unknown MAV_MISSION_RESULT {value!r} (known: {known})")


_TYPE_NAMES = {
    MISSION_TYPE.MISSION: "mission",
    MISSION_TYPE.FENCE: "fence",
    MISSION_TYPE.RALLY: "rally",
}


def mission_type_name(t: int) -> str:
    """ "mission", "fence" or "rally" (else the number).

    Args:
        t: a MAV_MISSION_TYPE number.

    Returns:
        "mission", "fence", "rally", or "mission type <t>".
    """
    return _TYPE_NAMES.get(int(t), f"mission type {t}")


# ----------------------------------------------------------------------------- endpoints


@dataclass(frozen=True)
class Endpoint:
    """A UDP endpoint: `udpin` listens on host:port, `udpout` sends to host:port."""

    mode: str  # "udpin" | "udpout"
    host: str
    port: int

    def url(self) -> str:
        """MAVSDK's spelling: udpin://host:port.

        Returns:
            "{mode}://{host}:{port}".
        """
        return f"{self.mode}://{self.host}:{self.port}"

    def __str__(self) -> str:
        return self.url()


def parse_endpoint(text: str) -> Endpoint:
    """`udpin://host:port`, `udpin:host:port`, `udpout:...` (and `udp:` = udpin, as mavutil).

    The mock vehicle speaks UDP only; the uploaders take every link
    `connection.parse_connection` knows (UDP, TCP, serial).

    Args:
        text: the endpoint (surrounding spaces ignored).

    Returns:
        The `Endpoint`; an empty udpin host is 0.0.0.0.

    Raises:
        ValueError: anything else (another scheme, no host, a port outside 1..65535).
    """
    raw = text.strip()
    mode, sep, rest = raw.partition(":")
    mode = mode.lower()
    if not sep or mode not in ("udp", "udpin", "udpout"):
        raise ValueError(f"{text!r}: expected udpin://HOST:PORT or udpout://HOST:PORT")
    if rest.startswith("//"):
        parts = urlsplit(raw)
        host, port = parts.hostname or "", parts.port
    else:
        host, _, p = rest.rpartition(":")
        port = int(p) if p.isdigit() else None
    if mode == "udp":
        mode = "udpin"
    if not host and mode == "udpin":
        host = "0.0.0.0"
    if not host or port is None or not 0 < port < 65536:
        raise ValueError(f"{text!r}: expected {mode}://HOST:PORT with a port 1..65535")
    return Endpoint(mode, host, int(port))


class PacketCapture:
    """The 'file' pymavlink's `MAVLink.send` writes packed bytes to: we send them ourselves."""

    def __init__(self) -> None:
        self.buf = b""

    def write(self, buf: bytes) -> None:
        """Keep the packed message (the last one only).

        Args:
            buf: the message's bytes, as pymavlink packs them.
        """
        self.buf = bytes(buf)


def open_udp(ep: Endpoint) -> tuple[socket.socket, tuple[str, int] | None]:
    """A non-blocking UDP socket for `ep` and the peer to send to (None for udpin, which answers
    whoever talks first). udpin binds the endpoint; udpout binds an ephemeral local port, on
    loopback when the peer is on loopback.

    Args:
        ep: the endpoint.

    Returns:
        (socket, peer): peer (ip, port) for udpout, its host resolved; None for udpin.

    Raises:
        OSError: the bind or the name lookup failed (the socket closed).
    """
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        peer = None
        if ep.mode == "udpin":
            sock.bind((ep.host, ep.port))
        else:
            loopback = ep.host in ("127.0.0.1", "localhost")
            sock.bind(("127.0.0.1" if loopback else "0.0.0.0", 0))
            peer = (socket.gethostbyname(ep.host), ep.port)
    except OSError:
        sock.close()
        raise
    sock.setblocking(False)
    return sock, peer

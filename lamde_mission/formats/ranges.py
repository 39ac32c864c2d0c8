"""MAVLink field ranges every mission item read from a file must meet, before it is replayed,
sent or compared.

MISSION_ITEM_INT (common.xml) carries: command uint16, frame uint8, current uint8, autocontinue
uint8, param1..4 float32, x/y int32 (degrees x 1e7 in global frames, metres x 1e4 in local
frames, the raw value in MAV_FRAME_MISSION), z float32; seq and count are uint16, so a mission
or a fence holds at most 65,535 items. The readers (`qgc_plan`, `waypoints`) call
`check_mission_item` on each item and `check_item_count` on each list, so `verify` and `upload`
see only items the wire can carry; the uploader (`lamde_mission.vehicle`) may call them again.

NaN is allowed where MAVLink gives it a meaning: param1..4 ("unset / keep the current value"),
x/y (sent as INT32_MAX, "unset") and z outside global frames. Latitudes lie in [-90, 90] and
longitudes in [-180, 180]; a global altitude must be finite. An altitude (z of any frame but
MAV_FRAME_MISSION, whose z is no position) must lie within +-`MAX_ALTITUDE` m, the most an
autopilot stores: ArduPilot's AP_Mission refuses |z| >= 83,000 m with MAV_MISSION_INVALID_PARAM7
(`LOCATION_ALT_MAX_M` in AP_Common/Location.h: its mission storage keeps altitudes in 24 bits
of centimetres); PX4 stores a float32 and sets no bound, so the tighter of the two applies to
every file. What the sim flies is tighter still (`sim.mission.MAX_FLIGHT_ALTITUDE`, 10 km).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from pymavlink.dialects.v20 import common as _mav

from lamde_mission.items import MissionError, MissionItem
from planner_core.textio import limit, quoted

__all__ = [
    "FLOAT32_MAX",
    "MAX_ALTITUDE",
    "GLOBAL_FRAMES",
    "check_mission_item",
    "check_item_count",
]

#: largest finite float32 (MAVLink's `float` fields)
FLOAT32_MAX = 3.4028234663852886e38
_INT32_MIN, _INT32_MAX = -(2**31), 2**31 - 1
#: |altitude| (m) an autopilot stores: ArduPilot refuses |z| >= this (LOCATION_ALT_MAX_M)
MAX_ALTITUDE = 83_000.0
_UINT = {"command": 0xFFFF, "frame": 0xFF, "current": 0xFF, "autocontinue": 0xFF}

#: frames whose x/y are latitude/longitude in degrees (int32 degrees x 1e7 on the wire)
GLOBAL_FRAMES = frozenset(
    {
        _mav.MAV_FRAME_GLOBAL,
        _mav.MAV_FRAME_GLOBAL_RELATIVE_ALT,
        _mav.MAV_FRAME_GLOBAL_INT,
        _mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        _mav.MAV_FRAME_GLOBAL_TERRAIN_ALT,
        _mav.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    }
)


def _shown(v: float) -> str:
    return f"{v:.10g}"


def check_mission_item(item: MissionItem, name: Callable[[str], str]) -> None:
    """Raise MissionError if a field of `item` is outside what MAVLink carries.

    `name(field)` turns "command", "frame", "current", "autocontinue", "param1".."param4",
    "x", "y" or "z" into the file's own name for it (e.g. "mission.items[3].params[0]" or
    "line 5: param1"), so the message names the field as the user sees it.

    Args:
        item: the item to check.
        name: field name -> the file's name for it.

    Raises:
        MissionError: the first field out of range: a non-integer or out-of-range command,
            frame, current or autocontinue; a param1..4 beyond float32; a non-finite or
            too-high altitude; a latitude/longitude out of range, or an x/y beyond int32.
    """
    for key, top in _UINT.items():
        v = getattr(item, key)
        if isinstance(v, bool) or not isinstance(v, int):
            raise MissionError(f"{name(key)}: must be an integer, got {quoted(v)}")
        if not 0 <= v <= top:
            raise MissionError(f"{name(key)}: {v} is outside 0..{top} (MAVLink's "
                               f"{'uint16' if top > 0xFF else 'uint8'})")  # fmt: skip
    for key in ("param1", "param2", "param3", "param4"):
        v = float(getattr(item, key))
        if math.isinf(v) or (not math.isnan(v) and abs(v) > FLOAT32_MAX):
            raise MissionError(f"{name(key)}: {_shown(v)} is beyond float32's range "
                               "(MAVLink carries it as a float32, at most 3.4e38)")  # fmt: skip
    frame = item.frame
    glob = frame in GLOBAL_FRAMES
    z = float(item.z)
    if math.isinf(z) or (glob and math.isnan(z)) or abs(z) > FLOAT32_MAX:
        raise MissionError(f"{name('z')}: altitude {_shown(z)} must be a finite float32 number")
    if frame != _mav.MAV_FRAME_MISSION and abs(z) >= MAX_ALTITUDE:
        raise MissionError(f"{name('z')}: {_shown(z)} m is not within +-{MAX_ALTITUDE:,.0f} "
                           "m, the most an autopilot stores as an altitude (ArduPilot's "
                           "LOCATION_ALT_MAX_M)")  # fmt: skip
    for key, bound in (("x", 90.0), ("y", 180.0)):
        v = float(getattr(item, key))
        if math.isnan(v):
            continue
        if glob:
            if not -bound <= v <= bound:
                what = "latitude" if key == "x" else "longitude"
                raise MissionError(f"{name(key)}: {what} {_shown(v)} is outside "
                                   f"[-{bound:g}, {bound:g}] degrees")  # fmt: skip
            continue
        scale = 1.0 if frame == _mav.MAV_FRAME_MISSION else 1e4
        if not (math.isfinite(v) and _INT32_MIN <= v * scale <= _INT32_MAX):
            raise MissionError(f"{name(key)}: {_shown(v)} does not fit MAVLink's int32 "
                               f"(frame {frame}, x {scale:g})")  # fmt: skip


def check_item_count(n: int, where: str) -> None:
    """Raise MissionError if `n` items exceed MAVLink's uint16 count (65,535).

    Args:
        n: the number of items.
        where: what holds them, for the message (e.g. "the file").

    Raises:
        MissionError: `n` exceeds the cap (`planner_core.textio.limit("mission_items")`).
    """
    cap = limit("mission_items")
    if n > cap:
        raise MissionError(f"{where}: {n:,} items, more than MAVLink's {cap:,} "
                           "(seq and count are uint16)")  # fmt: skip

"""Who claims to be the vehicle: the addresses each autopilot's HEARTBEATs come from.

On a link without signing, a MAVLink system is known only by the ids in its messages, and the
ground station listening on `udpin://` answers whoever sent the first HEARTBEAT. Two autopilots
claiming the same system and component ids from two addresses (a second vehicle with the same
MAV_SYS_ID, or someone playing the vehicle) cannot be told apart, and an upload would go to
whichever was heard first. Both uploaders therefore note every autopilot HEARTBEAT's source
address (`ClaimWatch`), listen for `HEARTBEAT_WATCH_S` from opening the link before the first
mission message is sent, and stop with `DuplicateVehicleError` (naming both addresses) when the
vehicle's ids arrive from a second address, then or at any later point of the session.

The pymavlink client watches its own link; MAVSDK, which follows a system id wherever it is
heard, talks to the vehicle through `relay.VehicleRelay`, which watches for it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from lamde_mission.vehicle.transfer import DuplicateVehicleError

__all__ = [
    "HEARTBEAT_WATCH_S",
    "ClaimWatch",
    "duplicate_error",
    "is_autopilot_heartbeat",
    "is_vehicle_heartbeat",
]

#: seconds both uploaders listen to HEARTBEATs, from opening the link, before anything that
#: changes the vehicle is sent: PX4 and ArduPilot send HEARTBEAT at 1 Hz (mavlink.io,
#: "Heartbeat/Connection Protocol"), so any 1.2 s of listening holds one from every autopilot
#: on the link, with 0.2 s for jitter
HEARTBEAT_WATCH_S = 1.2

#: MAV_AUTOPILOT_INVALID: a HEARTBEAT from something that is not a flight controller (a ground
#: station, a camera, a gimbal)
_AUTOPILOT_INVALID = 8
#: MAV_COMP_ID_AUTOPILOT1: the component both uploaders take for the vehicle
_COMP_AUTOPILOT1 = 1

Address = tuple[str, int]


def is_autopilot_heartbeat(msg: Any) -> bool:
    """Whether a parsed pymavlink message is a flight controller's HEARTBEAT (any component).

    Args:
        msg: a pymavlink message.

    Returns:
        True for a HEARTBEAT whose autopilot field is not MAV_AUTOPILOT_INVALID.
    """
    return msg.get_type() == "HEARTBEAT" and int(msg.autopilot) != _AUTOPILOT_INVALID


def is_vehicle_heartbeat(msg: Any) -> bool:
    """Whether `msg` is the HEARTBEAT an uploader takes for the vehicle: an autopilot's, from
    component MAV_COMP_ID_AUTOPILOT1.

    Args:
        msg: a pymavlink message.

    Returns:
        True for such a HEARTBEAT.
    """
    return is_autopilot_heartbeat(msg) and msg.get_srcComponent() == _COMP_AUTOPILOT1


def _where(addr: Address) -> str:
    return f"{addr[0]}:{addr[1]}"


def duplicate_error(
    ids: tuple[int, int], pinned: Address, other: Address, *, sent: bool
) -> DuplicateVehicleError:
    """The one-line error for two autopilots claiming `ids`.

    Args:
        ids: the (system, component) both claim.
        pinned: the address heard first (the one the uploader took for the vehicle).
        other: the second address.
        sent: whether mission messages had already gone to `pinned`.

    Returns:
        The error, naming both addresses.
    """
    done = "stopped" if sent else "nothing was sent"
    return DuplicateVehicleError(
        f"two autopilots claim system {ids[0]} component {ids[1]}: the one pinned at "
        f"{_where(pinned)} and another at {_where(other)}; {done}, since nothing on this link "
        "says which is the vehicle (a second vehicle with the same MAV_SYS_ID, or someone "
        "playing the vehicle: give each vehicle its own id, sign the link with --signing-key, "
        "or connect to the vehicle's own address with udpout:// or tcpout://)"
    )


class ClaimWatch:
    """The source addresses of every autopilot HEARTBEAT heard on one link, by (system,
    component), in the order first heard; opened when the link is.

    Args:
        window_s: how long to listen before sending (s); None: `HEARTBEAT_WATCH_S`, read when
            the watch opens.
        clock: the clock (seconds, monotonic).
    """

    def __init__(
        self, window_s: float | None = None, *, clock: Callable[[], float] = time.monotonic
    ) -> None:
        if window_s is None:
            window_s = HEARTBEAT_WATCH_S
        if not window_s >= 0:
            raise ValueError(f"the heartbeat watch must be >= 0 s, got {window_s!r}")
        self.window_s = float(window_s)
        self.opened = clock()
        self._seen: dict[tuple[int, int], list[Address]] = {}

    def ends_at(self) -> float:
        """When the listening before the first send is over (the watch's clock).

        Returns:
            opened + window_s, seconds on the watch's clock.
        """
        return self.opened + self.window_s

    def note(self, msg: Any, addr: Address | None) -> bool:
        """Record `msg`'s source if it is an autopilot HEARTBEAT from a network address.

        Args:
            msg: a parsed pymavlink message.
            addr: where it came from (None on a serial link: one sender only).

        Returns:
            Whether it was an autopilot HEARTBEAT from an address not heard before for its ids.
        """
        if addr is None or not is_autopilot_heartbeat(msg):
            return False
        seen = self._seen.setdefault((msg.get_srcSystem(), msg.get_srcComponent()), [])
        if addr in seen:
            return False
        seen.append(addr)
        return True

    def heard_systems(self) -> list[int]:
        """The system ids of every vehicle (component 1) whose HEARTBEAT was noted, sorted.

        Returns:
            Distinct MAVLink system ids, ascending.
        """
        return sorted({s for (s, c) in self._seen if c == _COMP_AUTOPILOT1})

    def conflict(self, ids: tuple[int, int], pinned: Address | None) -> Address | None:
        """A second address claiming `ids`, other than `pinned`, if one was heard.

        Args:
            ids: the vehicle's (system, component).
            pinned: the address taken for the vehicle (None: a serial link, no conflict).

        Returns:
            The first other address heard for `ids`, or None.
        """
        if pinned is None:
            return None
        return next((a for a in self._seen.get(ids, ()) if a != pinned), None)

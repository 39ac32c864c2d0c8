"""Upload a mission and its geofence, read them back, compare: `upload_mission`.

This is the only module that imports MAVSDK (`mavsdk` 4.x, the native binding; imported when a
`MavsdkClient` is made, so `via="pymavlink"` never loads it). `MavsdkClient` drives MAVSDK's
MissionRaw plugin (raw MISSION_ITEM_INT lists for the mission, fence and rally points) from a
private asyncio loop and is a `MissionClient` for `transfer.upload_and_verify`;
`MavlinkClient` (pymavlink) is the other.

Conventions (see `wire.py`): items go up numbered 0..n-1 with item 0 marked current; the
read-back is compared item by item after MAVLink's int32/float32 conversions. `.waypoints`
files: the home line (seq 0 of the file) is not uploaded; `read_mission` drops it and the
mission starts at seq 0 with our first item, exactly as the `.plan` of the same plan does, so
both formats upload and read back the same items. For an ArduPilot vehicle (HEARTBEAT autopilot
MAV_AUTOPILOT_ARDUPILOTMEGA, or `autopilot="ardupilot"`) a home placeholder goes up first as
item 0, which ArduPilot overwrites with its home and never flies, and DO_JUMP targets move up
with the items; the read-back is compared under its storage rules.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Literal

from lamde_mission.items import MISSION_TYPE, MissionItem
from lamde_mission.storage import dialect_for_autopilot
from lamde_mission.vehicle.claims import duplicate_error
from lamde_mission.vehicle.connection import Connection, parse_connection
from lamde_mission.vehicle.transfer import (
    DuplicateVehicleError,
    MissionRejectedError,
    NoVehicleError,
    TransferError,
    UploadReport,
    VehicleError,
    VehicleInfo,
    no_vehicle_message,
    upload_and_verify,
)
from lamde_mission.vehicle.wire import WireItem, mission_type_name
from planner_core.textio import counted

__all__ = ["MavsdkClient", "upload_mission", "make_client", "VIAS"]

#: the uploaders `upload_mission` can use
VIAS = ("mavsdk", "pymavlink")

#: MissionRaw results that mean "try the transfer again"
_RETRYABLE = {"TIMEOUT", "BUSY", "ERROR", "UNKNOWN", "PROTOCOL_ERROR", "TRANSFER_CANCELLED",
              "NO_SYSTEM"}  # fmt: skip
#: the MISSION_ACK code behind a MissionRaw result, where it is one code
_ACK_OF_RESULT = {
    "TOO_MANY_MISSION_ITEMS": "MAV_MISSION_NO_SPACE",
    "DENIED": "MAV_MISSION_DENIED",
    "INVALID_SEQUENCE": "MAV_MISSION_INVALID_SEQUENCE",
    "PROTOCOL_ERROR": "MAV_MISSION_ERROR",
    "TRANSFER_CANCELLED": "MAV_MISSION_OPERATION_CANCELLED",
    "UNSUPPORTED": "MAV_MISSION_UNSUPPORTED or MAV_MISSION_UNSUPPORTED_FRAME",
    "INVALID_ARGUMENT": "MAV_MISSION_INVALID or MAV_MISSION_INVALID_PARAMn",
}


_log = logging.getLogger("lamde_mission.vehicle.mavsdk")
#: without it a program that configures no logging would get MAVSDK's errors on stderr anyway,
#: through logging's last-resort handler (a bare "Retrying failed" from MAVSDK's parameter
#: client, after an unanswered MPC_XY_VEL_MAX read): a library's loggers stay silent unless
#: the program sets a handler (`upload --verbose` does, or `logging.basicConfig`)
_log.addHandler(logging.NullHandler())


#: s, the longest `timeout` an upload takes: an hour without progress is a dead link (MAVSDK
#: turned 1e10 s into an immediate "no vehicle heard ... within 1e+10 s")
MAX_TIMEOUT_S = 3600.0


def _route_mavsdk_log() -> None:
    """Send MAVSDK's own log lines to Python logging ("lamde_mission.vehicle.mavsdk") instead
    of the terminal: its errors as warnings, the rest at debug level (our report says what
    failed). They reach stderr only through a handler the program sets (the logger has a
    NullHandler, so logging's last resort does not print them)."""
    from mavsdk import LogLevel, log_subscribe

    def handler(level: Any, message: str, file: str | None, line: int) -> bool:
        _log.log(logging.WARNING if level >= LogLevel.ERROR else logging.DEBUG, "%s", message)
        return True  # handled: MAVSDK prints nothing

    log_subscribe(handler)


#: MAVSDK's limits on one mission item (MAVSDK 4.1, cpp/src/mavsdk/core/
#: mavlink_mission_transfer_client.hpp `retries = 5`, a constant; mavsdk_impl.hpp
#: DEFAULT_TIMEOUT_S = 0.5, the message timeout). An upload item fails when MAVSDK has sent it
#: 5 times (each send answers a vehicle's request) or counted 5 of sends and silent
#: timeouts together and hears a sixth; a download item after 5 requests. docs/upload.md
#: works out what that means on a lossy link.
MAVSDK_ITEM_TIMEOUT_S = 0.5
MAVSDK_RETRIES = 5

#: MAVSDK's message timeout during an upload, by the vehicle's autopilot: the vehicle's own
#: give-up time over MAVSDK's 5 counts (PX4 5 s, ArduPilot 8 s; see mock.UPLOAD_TIMING), so
#: that a silence only counts once the vehicle has missed more than one of its re-requests
#: (PX4 every 0.25 s, ArduPilot every 1 s; with MAVSDK's 0.5 s each missing ArduPilot item
#: costs three of its five counts). Downloads keep MAVSDK's 0.5 s: there MAVSDK itself asks
#: again after each timeout, and only the number of requests (5) limits it.
MAVSDK_UPLOAD_TIMEOUT_S = {"px4": 1.0, "ardupilot": 1.6}
MAVSDK_UPLOAD_TIMEOUT_DEFAULT_S = 1.6

#: s, what MAVSDK gets beyond its own time-out to return while connecting (`first_autopilot`
#: given `timeout`; the vehicle's autopilot and type): past it, MAVSDK is taken to hang
CONNECT_MARGIN_S = 5.0


class MavsdkClient:
    """Mission transfers through MAVSDK's MissionRaw plugin (blocking calls, own event loop).

    MAVSDK owns its link: it pins nothing by address, and its mission transfer recovers lost
    messages itself (re-requesting a download item or resending the count up to
    `MAVSDK_RETRIES` times, a message timeout apart; it never resends an upload item unasked,
    the vehicle re-requests), then fails the whole list with TIMEOUT; `upload_and_verify` then
    retries the whole transfer. MAVSDK's TIMEOUT does not say whether the vehicle answered at
    all; the relay's count of the vehicle's item requests and ACKs does (`upload`: a list
    never answered is `TransferError.unanswered`, and no read-back is tried). The count of 5
    is a constant in MAVSDK. The message timeout is `Mavsdk::set_timeout_s`, which
    MAVSDK-Python 4.1 does not wrap; this client calls the C API under it (cmavsdk's
    `mavsdk_set_timeout_s`, in the library the package ships) before each transfer:
    `MAVSDK_UPLOAD_TIMEOUT_S` for uploads, MAVSDK's 0.5 s for downloads. Where that function
    is missing, MAVSDK's 0.5 s stays (`message_timeout_settable` is False).
    """

    name = "mavsdk"

    def __init__(
        self, connect: str | Connection = "udpin://0.0.0.0:14540", *, quiet: bool = True,
        signing_key: bytes | None = None, heartbeat_watch: float | None = None,
        system_id: int | None = None,
    ) -> None:
        #: the vehicle's MAVLink system id to talk to (None: the first vehicle heard)
        self.target_system = None if system_id is None else int(system_id)
        try:
            conn = connect if isinstance(connect, Connection) else parse_connection(connect)
        except ValueError as exc:
            raise VehicleError(str(exc)) from None
        #: MAVSDK talks to a local `relay.VehicleRelay` holding the vehicle's link: it pins
        #: the vehicle's address, watches for a second autopilot claiming its ids, and signs
        #: for MAVSDK (MAVSDK-Python 4 cannot) on a signed link
        from lamde_mission.vehicle.relay import VehicleRelay

        try:
            self._relay: Any = VehicleRelay(
                conn, signing_key, heartbeat_watch=heartbeat_watch, system_id=self.target_system
            )
        except OSError as exc:
            raise VehicleError(f"cannot open {conn}: {exc.strerror or exc}") from None
        #: where MAVSDK connects (the relay's local socket); `endpoint`: the vehicle's link
        self.url = self._relay.url
        self.endpoint = conn.url()
        #: whether a message that changes the vehicle (an upload, a clear) has been started
        self.sent = False
        self._expected: dict[int, int] = {}
        from mavsdk.asyncio import ComponentType, Configuration, Mavsdk

        if quiet:
            _route_mavsdk_log()
        cfg = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
        self._sdk: Any = Mavsdk(cfg)
        self._loop = asyncio.new_event_loop()
        self._system: Any = None
        self._raw: Any = None
        self.vehicle: VehicleInfo | None = None
        self._set_timeout = _timeout_setter(self._sdk)
        #: whether MAVSDK's message timeout can be set (cmavsdk's mavsdk_set_timeout_s found)
        self.message_timeout_settable = self._set_timeout is not None

    def _message_timeout(self, seconds: float) -> None:
        """MAVSDK's message timeout for the transfers started from now on (it reads it when a
        transfer starts); nothing where it cannot be set."""
        if self._set_timeout is not None:
            self._set_timeout(seconds)

    def upload_message_timeout(self) -> float:
        """The message timeout this client gives MAVSDK for an upload to this vehicle.

        Returns:
            Seconds: `MAVSDK_UPLOAD_TIMEOUT_S` for the connected vehicle's autopilot,
            `MAVSDK_UPLOAD_TIMEOUT_DEFAULT_S` for another autopilot or before `connect`.
        """
        if self.vehicle is None:
            return MAVSDK_UPLOAD_TIMEOUT_DEFAULT_S
        dialect = dialect_for_autopilot(self.vehicle.autopilot).name
        return MAVSDK_UPLOAD_TIMEOUT_S.get(dialect, MAVSDK_UPLOAD_TIMEOUT_DEFAULT_S)

    # ------------------------------------------------------------------ plumbing

    def _run(self, coro: Any, timeout: float) -> Any:
        """Run `coro` on the private loop for at most `timeout` s (TimeoutError); stopped
        with `DuplicateVehicleError` as soon as the relay hears a second autopilot with the
        vehicle's ids."""

        async def guarded() -> Any:
            task = asyncio.ensure_future(coro)
            try:
                while True:
                    self._raise_if_claimed()
                    done, _ = await asyncio.wait({task}, timeout=0.05)
                    if done:
                        return task.result()
            finally:
                if not task.done():
                    task.cancel()
                    with contextlib.suppress(BaseException):
                        await task

        try:
            return self._loop.run_until_complete(asyncio.wait_for(guarded(), timeout))
        except KeyboardInterrupt:  # Ctrl-C: its tasks ended here, not destroyed pending later
            self._cancel_pending()
            raise

    def _cancel_pending(self) -> None:
        """Cancel the loop's unfinished tasks and let them unwind (their `finally` blocks
        run on the open loop), so closing the loop leaves no pending task behind."""
        if self._loop.is_closed():
            return
        pending = [t for t in asyncio.all_tasks(self._loop) if not t.done()]
        for t in pending:
            t.cancel()
        if pending:
            with contextlib.suppress(BaseException):
                self._loop.run_until_complete(asyncio.gather(*pending, return_exceptions=True))

    def _raise_if_claimed(self) -> None:
        """DuplicateVehicleError once the relay has heard the vehicle's ids from a second
        address."""
        relay = self._relay
        if relay is not None and relay.conflict is not None:
            assert relay.vehicle_ids is not None and relay.vehicle_addr is not None
            raise duplicate_error(relay.vehicle_ids, relay.vehicle_addr, relay.conflict,
                                  sent=self.sent)  # fmt: skip

    def ignored_lines(self) -> list[str]:
        """What the relay kept from MAVSDK (wrongly signed, from other addresses), counted.

        Returns:
            The relay's lines (`VehicleRelay.ignored_lines`); empty once closed.
        """
        return self._relay.ignored_lines() if self._relay is not None else []

    def close(self) -> None:
        """Release MAVSDK (its threads and sockets) and the event loop (idempotent).

        The loop's executor is shut down first: a MAVSDK call still running there (one given
        up by a time-out or a second autopilot) returns before MAVSDK is destroyed under it,
        which would never return."""
        self._cancel_pending()
        if not self._loop.is_closed():
            self._loop.run_until_complete(self._loop.shutdown_default_executor())
        if self._sdk is not None:
            sdk, self._sdk = self._sdk, None
            self._raw = None
            self._system = None
            sdk.destroy()
        if self._relay is not None:
            self._relay.close()
            self._relay = None
        if not self._loop.is_closed():
            self._loop.close()

    def __enter__(self) -> MavsdkClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ connect

    def connect(self, timeout: float) -> VehicleInfo:
        """Listen/connect at the URL and wait up to `timeout` s for an autopilot, then for the
        rest of the relay's HEARTBEAT watch (`claims.HEARTBEAT_WATCH_S`).

        Args:
            timeout: seconds to wait for the first autopilot.

        Returns:
            Who answered, named from the HEARTBEAT the relay pinned the vehicle by
            (`VehicleInfo.from_heartbeat`, the pymavlink client's words).

        Raises:
            VehicleError: MAVSDK cannot open its link to the relay, or does not return
                within `CONNECT_MARGIN_S` beyond its own time-out (it hangs).
            NoVehicleError: no autopilot (or not the system id asked for) within `timeout`.
            DuplicateVehicleError: a second autopilot claims the vehicle's ids.
        """
        from mavsdk.asyncio import MavsdkConnectionError
        from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync

        async def go() -> Any:
            try:
                await self._sdk.add_any_connection(self.url)
            except MavsdkConnectionError as exc:
                raise VehicleError(f"cannot open MAVSDK's link to the relay at {self.url}: "
                                   f"{exc}") from None  # fmt: skip
            return await self._sdk.first_autopilot(timeout_s=float(timeout))

        def step(coro: Any, limit: float, what: str) -> Any:
            try:
                return self._run(coro, limit)
            except TimeoutError:  # MAVSDK's own time-out passed long ago: it hangs
                raise VehicleError(f"MAVSDK did not return within {limit:g} s while {what} at "
                                   f"{self.endpoint}; try --via pymavlink") from None

        system = step(go(), timeout + CONNECT_MARGIN_S, "waiting for the vehicle")
        if system is None:
            heard = self._relay.watch.heard_systems()
            raise NoVehicleError(no_vehicle_message(
                self.endpoint, timeout, self.target_system, heard, self._relay.dropped))
        self._system = system
        self._raw = MissionRawAsync(system)

        # named from the HEARTBEAT the relay pinned the vehicle by (MAVSDK hears the vehicle
        # only through the relay, after the pin), as the pymavlink client names it: MAVSDK's
        # own vehicle_type() knows only coarse classes ("multicopter" for a quadrotor)
        self.vehicle = VehicleInfo.from_heartbeat(self._relay.vehicle_heartbeat)
        # the rest of the watch before anything is sent (`claims.HEARTBEAT_WATCH_S`)
        left = self._relay.watch.ends_at() - time.monotonic()
        if left > 0:
            step(asyncio.sleep(left), left + CONNECT_MARGIN_S, "watching for a second autopilot")
        self._raise_if_claimed()
        return self.vehicle

    def read_param(self, name: str, timeout: float) -> float | None:
        """One float parameter of the vehicle through MAVSDK's Param plugin
        (`get_param_float`: the MAVLink parameter protocol).

        Args:
            name: the parameter's id, at most 16 characters.
            timeout: seconds to wait, > 0 (MAVSDK's own retries run inside it).

        Returns:
            Its value, or None when MAVSDK gets no answer in time or the vehicle has no such
            float parameter.

        Raises:
            TransferError: not connected.
        """
        from mavsdk.asyncio.plugins.param import ParamAsync, ParamError

        if self._system is None:
            raise TransferError("not connected (call connect first)")

        async def get() -> float | None:
            try:
                return float(await ParamAsync(self._system).get_param_float(name))
            except ParamError:
                return None

        try:
            return self._run(get(), float(timeout))
        except TimeoutError:
            return None

    # ------------------------------------------------------------------ transfers

    def _call(
        self,
        what: str,
        mission_type: int,
        timeout: float,
        fn: Callable[[], Any],
        cancel: Callable[[], Any] | None = None,
        unanswered: Callable[[str], str | None] | None = None,
    ) -> Any:
        """Run one MAVSDK transfer call `fn()` for at most `timeout` s.

        Args:
            what: the step, for messages ("upload", "download", "clear", "import").
            mission_type: MAV_MISSION_TYPE of the list.
            timeout: seconds for the whole call.
            fn: makes the call's coroutine.
            cancel: makes the coroutine that cancels the transfer (after a time-out).
            unanswered: for a time-out (MAVSDK's TIMEOUT or ours), called with what timed
                out; returns the TransferError's line when the vehicle answered nothing of
                the transfer (the error is then `unanswered`), None when it did.

        Returns:
            What the call returns.

        Raises:
            TransferError: not connected, or a time-out.
            MissionRejectedError: MAVSDK's other results (the vehicle's ACK code named).
            DuplicateVehicleError: a second autopilot claims the vehicle's ids.
        """
        from mavsdk.asyncio.plugins.geofence import GeofenceError
        from mavsdk.asyncio.plugins.mission_raw import MissionRawError

        if self._raw is None:
            raise TransferError("not connected (call connect first)")
        kind = mission_type_name(mission_type)
        try:
            return self._run(fn(), timeout)
        except DuplicateVehicleError:
            # MAVSDK's blocking call still runs in the loop's executor: cancel the transfer
            # (not through `_run`, which would stop at once) so that it returns before close()
            if cancel is not None:
                with contextlib.suppress(Exception):
                    self._loop.run_until_complete(asyncio.wait_for(cancel(), 5.0))
            raise
        except TimeoutError:
            if cancel is not None:
                with contextlib.suppress(Exception):  # nothing left to cancel
                    self._run(cancel(), 5.0)
            silent = unanswered(f"MAVSDK: no result within {timeout:.3g} s") if unanswered \
                else None  # fmt: skip
            if silent is not None:
                raise TransferError(silent, unanswered=True) from None
            raise TransferError(f"{kind} {what}: no result within {timeout:.3g} s") from None
        except (MissionRawError, GeofenceError) as exc:
            name = exc.result.name
            source = "MissionRaw" if isinstance(exc, MissionRawError) else "Geofence"
            if name == "TIMEOUT":
                silent = unanswered(f"{source} result TIMEOUT") if unanswered else None
                if silent is not None:
                    raise TransferError(silent, unanswered=True) from None
                raise TransferError(f"{kind} {what} timed out ({source} result TIMEOUT)") from None
            ack = _ACK_OF_RESULT.get(name)
            shown = f"{name} ({source} result{'; ' + ack if ack else ''})"
            raise MissionRejectedError(
                f"the vehicle refused the {kind} {what}: {shown}",
                name=name, mission_type=mission_type, retryable=name in _RETRYABLE,
            ) from None  # fmt: skip

    def upload(self, items: Sequence[WireItem], mission_type: int, timeout: float) -> None:
        """Upload one list through MissionRaw (mission, geofence or rally points).

        Args:
            items: the list (`wire_mission`).
            mission_type: MAV_MISSION_TYPE mission, fence or rally.
            timeout: seconds; the call's limit adds what MAVSDK's own retries may take per
                item (`_limit`).

        Raises:
            TransferError: not connected, or no result in time (or MAVSDK's TIMEOUT);
                `unanswered` when the relay passed MAVSDK no item request and no
                MISSION_ACK of this list meanwhile (nothing reached the vehicle: the line
                says so, as the pymavlink client's does).
            MissionRejectedError: the vehicle (or MAVSDK) refused the list.
            DuplicateVehicleError: a second autopilot claims the vehicle's ids.
        """
        from mavsdk.asyncio.plugins.mission_raw import MissionItem as RawItem

        raw_items = [RawItem(*w.fields()) for w in items]
        self._expected[int(mission_type)] = len(raw_items)
        per_message = self.upload_message_timeout() if self.message_timeout_settable else None
        timeout = self._limit(timeout, len(raw_items), per_message)
        up = {
            MISSION_TYPE.MISSION: self._raw.upload_mission,
            MISSION_TYPE.FENCE: self._raw.upload_geofence,
            MISSION_TYPE.RALLY: self._raw.upload_rally_points,
        }[int(mission_type)]
        if per_message is not None:
            self._message_timeout(per_message)
        t, n = int(mission_type), len(raw_items)
        before = self._relay.mission_answers(t)
        self.sent = True
        try:
            self._call(
                "upload", mission_type, timeout, lambda: up(raw_items),
                self._raw.cancel_mission_upload,
                lambda why: self._no_answer_line(t, n, before, why),
            )  # fmt: skip
        finally:
            self._message_timeout(MAVSDK_ITEM_TIMEOUT_S)

    def _no_answer_line(self, mission_type: int, n: int, before: int, why: str) -> str | None:
        """The line of an upload the vehicle never answered, or None when it answered.

        Args:
            mission_type: MAV_MISSION_TYPE of the list.
            n: the list's items.
            before: `relay.mission_answers(mission_type)` when the upload started.
            why: what timed out (MAVSDK's result, or our limit).

        Returns:
            pymavlink's words for it ("mission upload: no answer from the vehicle while
            waiting for the first item request (0 of 6 items sent; why)") when the relay
            passed MAVSDK no item request and no MISSION_ACK of the list since `before`;
            None when it did (the vehicle heard the count: the read-back decides).
        """
        if self._relay is None or self._relay.mission_answers(mission_type) != before:
            return None
        return (f"{mission_type_name(mission_type)} upload: no answer from the vehicle while "
                f"waiting for the first item request (0 of {counted(n, 'item')} sent; {why})")

    @staticmethod
    def _limit(timeout: float, n: int, per_message: float | None = None) -> float:
        """The whole call's limit: `timeout`, plus what MAVSDK's own retries may take per item
        (MAVSDK reports no progress we could reset a no-progress timer on)."""
        per = MAVSDK_ITEM_TIMEOUT_S if per_message is None else per_message
        return timeout + n * per * (MAVSDK_RETRIES + 1)

    def download(self, mission_type: int, timeout: float) -> list[WireItem]:
        """Read one list back through MissionRaw (MAVSDK's 0.5 s message timeout).

        Args:
            mission_type: MAV_MISSION_TYPE mission, fence or rally.
            timeout: seconds; the call's limit adds what MAVSDK's own retries may take per
                item uploaded last (`_limit`).

        Returns:
            The items the vehicle holds.

        Raises:
            TransferError: not connected, or no result in time (or MAVSDK's TIMEOUT).
            MissionRejectedError: the vehicle (or MAVSDK) refused the download.
            DuplicateVehicleError: a second autopilot claims the vehicle's ids.
        """
        self._message_timeout(MAVSDK_ITEM_TIMEOUT_S)
        timeout = self._limit(timeout, self._expected.get(int(mission_type), 0))
        down = {
            MISSION_TYPE.MISSION: self._raw.download_mission,
            MISSION_TYPE.FENCE: self._raw.download_geofence,
            MISSION_TYPE.RALLY: self._raw.download_rallypoints,
        }[int(mission_type)]
        got = self._call("download", mission_type, timeout, down, self._raw.cancel_mission_download)
        return [_wire_of(r) for r in got]

    def clear(self, mission_type: int, timeout: float) -> None:
        """Clear the mission (MissionRaw) or the geofence (Geofence plugin) on the vehicle.

        Args:
            mission_type: MAV_MISSION_TYPE mission or fence.
            timeout: seconds.

        Raises:
            ValueError: rally points (MAVSDK has no call to clear them).
            TransferError: not connected, or no result in time.
            MissionRejectedError: the vehicle refused.
            DuplicateVehicleError: a second autopilot claims the vehicle's ids.
        """
        t = int(mission_type)
        self.sent = True
        if t == MISSION_TYPE.MISSION:
            self._call("clear", t, timeout, self._raw.clear_mission)
        elif t == MISSION_TYPE.FENCE:
            from mavsdk.asyncio.plugins.geofence import GeofenceAsync

            fence = GeofenceAsync(self._system)
            try:
                self._call("clear", t, timeout, fence.clear_geofence)
            finally:
                fence.destroy()
        else:
            raise ValueError("MAVSDK has no call to clear rally points")

    def import_qgc_plan(
        self, path: str | Path
    ) -> tuple[list[WireItem], list[WireItem], list[WireItem]]:
        """MAVSDK's own QGroundControl importer on `path`: (mission, fence, rally) as WireItems.

        Needs a connected vehicle (MAVSDK asks it for its autopilot type: for ArduPilot it puts
        the planned home in as item 0).

        Args:
            path: the `.plan` file.

        Returns:
            (mission, fence, rally) lists of `WireItem`.

        Raises:
            MissionRejectedError: naming MAVSDK's result (e.g. FAILED_TO_PARSE_QGC_PLAN) when
                it refuses the file.
            TransferError: not connected, or no result within 10 s.
        """
        try:
            data = self._call(
                "import",
                MISSION_TYPE.MISSION,
                10.0,
                lambda: self._raw.import_qgroundcontrol_mission(str(path)),
            )
        except MissionRejectedError as exc:
            raise MissionRejectedError(
                f"MAVSDK's QGroundControl importer refused {path}: {exc.name}", name=exc.name
            ) from None
        return (
            [_wire_of(r) for r in data.mission_items],
            [_wire_of(r) for r in data.geofence_items],
            [_wire_of(r) for r in data.rally_items],
        )


def _timeout_setter(sdk: Any) -> Callable[[float], None] | None:
    """`seconds -> None` setting MAVSDK's message timeout (Mavsdk::set_timeout_s) through the
    C API under MAVSDK-Python 4.x (cmavsdk's `mavsdk_set_timeout_s(mavsdk_t, double)`, in
    c/src/cmavsdk/mavsdk.h; the Python package ships that library but does not wrap the
    call); None where this binding has no such function."""
    import ctypes

    inner = getattr(sdk, "_mavsdk", None)
    lib, handle = getattr(inner, "_lib", None), getattr(inner, "_handle", None)
    fn = getattr(lib, "mavsdk_set_timeout_s", None) if lib is not None else None
    if fn is None or not handle:
        _log.debug("MAVSDK's message timeout cannot be set here; it stays at its 0.5 s")
        return None
    fn.argtypes = [ctypes.c_void_p, ctypes.c_double]
    fn.restype = None

    def set_timeout(seconds: float) -> None:
        if getattr(inner, "_handle", None):  # not after close()
            fn(inner._handle, float(seconds))

    return set_timeout


def _wire_of(r: Any) -> WireItem:
    f32 = [float(v) for v in (r.param1, r.param2, r.param3, r.param4, r.z)]
    return WireItem(
        int(r.seq), int(r.frame), int(r.command), int(r.current), int(r.autocontinue),
        f32[0], f32[1], f32[2], f32[3], int(r.x), int(r.y), f32[4], int(r.mission_type),
    )  # fmt: skip


def make_client(
    via: str,
    connect: str | Connection,
    *,
    log: Callable[[str], None] | None = None,
    progress: Callable[[str, int, int], None] | None = None,
    signing_key: bytes | None = None,
    heartbeat_watch: float | None = None,
    system_id: int | None = None,
) -> Any:
    """A MissionClient: "mavsdk" (MAVSDK's MissionRaw) or "pymavlink" (ours).

    Args:
        via: "mavsdk" or "pymavlink".
        connect: the vehicle's connection.
        log: gets what the client ignored and recovered (pymavlink).
        progress: `progress(what, done, total)` per item (pymavlink).
        signing_key: signs the link (MAVSDK through its `relay.VehicleRelay`).
        heartbeat_watch: seconds of HEARTBEATs listened to before the first send (None:
            `claims.HEARTBEAT_WATCH_S`, read at the call).
        system_id: the vehicle's MAVLink system id, on a link several vehicles share (None:
            the first vehicle heard).

    Returns:
        The client, its link open.

    Raises:
        ValueError: `via` is neither.
        VehicleError: the link cannot be opened.
    """
    if via == "mavsdk":
        return MavsdkClient(connect, signing_key=signing_key, heartbeat_watch=heartbeat_watch,
                            system_id=system_id)  # fmt: skip
    if via == "pymavlink":
        from lamde_mission.vehicle.mavlink_client import MavlinkClient

        return MavlinkClient(connect, log=log, progress=progress, signing_key=signing_key,
                             heartbeat_watch=heartbeat_watch,
                             target_system=system_id)  # fmt: skip
    raise ValueError(f"via must be one of {', '.join(VIAS)}, got {via!r}")


def upload_mission(
    mission: Sequence[MissionItem],
    fence: Sequence[MissionItem] | None = (),
    *,
    connect: str = "udpin://0.0.0.0:14540",
    via: str = "mavsdk",
    timeout: float = 30.0,
    attempts: int = 3,
    log: Callable[[str], None] | None = None,
    progress: Callable[[str, int, int], None] | None = None,
    rally: Sequence[MissionItem] | None = None,
    autopilot: str | None = None,
    signing_key: bytes | None = None,
    heartbeat_watch: float | None = None,
    system_id: int | None = None,
    speed_check: Callable[[str, float], str | None] | None | Literal["planned"] = "planned",
) -> UploadReport:
    """Upload a mission and its fence to the vehicle at `connect`, read both back, compare.

    `fence=None` leaves the vehicle's fence alone (a `.waypoints` file has none); an empty
    fence clears it. `rally` (MISSION_TYPE_RALLY items; None leaves the vehicle's alone) goes up
    as the rally list. `autopilot` (px4, ardupilot, generic) overrides the storage rules read
    from the vehicle's HEARTBEAT (`transfer.upload_and_verify`). Waits up to `timeout` s for
    the vehicle; a list's transfer gives up after `timeout` s without progress (lost messages
    are re-requested one by one); a failed attempt (time-out, read-back difference) is retried
    as a whole up to `attempts` times. `connect` is checked first
    (`connection.parse_connection`), and every item against MAVLink's field types before the
    client is made: nothing is sent that the wire cannot carry. Both clients listen to
    HEARTBEATs for `heartbeat_watch` s from opening the link before anything is sent.

    Args:
        mission: the mission items.
        fence: the fence items; None leaves the vehicle's fence alone (a `.waypoints` file
            has none), empty clears it.
        rally: MISSION_TYPE_RALLY items, uploaded as the rally list; None leaves the
            vehicle's alone.
        connect: the vehicle's connection (`connection.parse_connection`).
        via: "mavsdk" or "pymavlink" (`VIAS`).
        timeout: seconds, in (0, `MAX_TIMEOUT_S`]: the wait for the vehicle, and per list
            without progress.
        attempts: how many times a failed attempt is tried as a whole.
        log: called with a line per step and what the client ignored or recovered.
        progress: `progress(what, done, total)` per item (pymavlink).
        autopilot: px4, ardupilot or generic: overrides the storage rules read from the
            vehicle's HEARTBEAT (`transfer.upload_and_verify`).
        signing_key: 32 bytes (`signing.signing_key`): signs the link with MAVLink 2
            signing; the vehicle's unsigned or wrongly signed messages are ignored (MAVSDK,
            which cannot sign, talks through its local `relay.VehicleRelay`, which signs).
        heartbeat_watch: seconds of HEARTBEATs listened to before the first send (None:
            `claims.HEARTBEAT_WATCH_S`, read at the call).
        system_id: picks the vehicle by its MAVLink system id (1..255) on a link several
            vehicles share (a multi-vehicle radio or router; `upload_fleet`): its HEARTBEAT
            is waited for, and only its messages are listened to; None takes the first
            vehicle heard.
        speed_check: after connecting and before anything is sent, the vehicle's horizontal
            speed limit is read (`transfer.SPEED_LIMIT_PARAM`, where its dialect has one;
            `report.speed_limit`) and `speed_check(parameter, m/s)` judges it; a line refuses
            the upload (`SpeedLimitError`, nothing sent). "planned" (the default):
            `speeds.mission_speed_check(mission)`, the check of `upload MISSION` without
            --map for a mission of no known file: a limit no mission flies at is refused, one
            below the mission's DO_CHANGE_SPEED warned about (`speeds.SpeedLimitWarning`; no
            battery known). `mission_speed_check(mission, source=path)` also refuses a sortie
            of a directory planned with a battery, `map=m` judges the mission on the map at
            the limit, `force=True` warns instead of refusing. None skips the check and reads
            nothing.

    Returns:
        The report, with what the client ignored among its notes.

    Raises:
        VehicleError: the link cannot be opened; a subclass (NoVehicleError,
            MissionRejectedError, TransferError, ReadbackMismatchError; `.report` attached)
            on failure of the transfer; `DuplicateVehicleError`
            (naming both addresses) when a second address claims the vehicle's system and
            component ids, during the watch or later (`claims`); `SpeedLimitError` (nothing
            sent) with `speed_check`'s line.
        ValueError: bad arguments (timeout, via, connect, system_id, attempts, autopilot,
            speed_check) or items MAVLink cannot carry.
    """
    if not (isinstance(timeout, int | float) and math.isfinite(timeout)
            and 0 < timeout <= MAX_TIMEOUT_S):  # fmt: skip
        raise ValueError(f"timeout must be a number of seconds in (0, {MAX_TIMEOUT_S:g}], "
                         f"got {timeout!r}")
    if via not in VIAS:
        raise ValueError(f"via must be one of {', '.join(VIAS)}, got {via!r}")
    conn = parse_connection(connect)  # ValueError, one line
    from lamde_mission.vehicle.wire import wire_mission

    wire_mission(mission, MISSION_TYPE.MISSION)  # ValueError naming item and field
    if fence:
        wire_mission(fence, MISSION_TYPE.FENCE)
    if rally:
        wire_mission(rally, MISSION_TYPE.RALLY)
    if system_id is not None and not 1 <= int(system_id) <= 255:
        raise ValueError(f"system_id must be a MAVLink system id 1..255, got {system_id!r}")
    if speed_check == "planned":
        from lamde_mission.vehicle.speeds import mission_speed_check

        speed_check = mission_speed_check(mission)
    elif isinstance(speed_check, str):
        raise ValueError(f'speed_check must be a function, "planned" or None, got '
                         f"{speed_check!r}")
    client = make_client(via, conn, log=log, progress=progress, signing_key=signing_key,
                         heartbeat_watch=heartbeat_watch, system_id=system_id)  # fmt: skip
    try:
        report = upload_and_verify(
            client, mission, fence, rally=rally, autopilot=autopilot, timeout=timeout,
            attempts=attempts, endpoint=connect, log=log, speed_check=speed_check,
        )  # fmt: skip
    except VehicleError as exc:
        if exc.report is not None:
            exc.report.notes.extend(getattr(client, "ignored_lines", list)())
        raise
    finally:
        client.close()
    report.notes.extend(getattr(client, "ignored_lines", list)())
    return report

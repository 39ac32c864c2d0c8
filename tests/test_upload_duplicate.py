"""Two autopilots claiming system 1 from two addresses (issue 32, item 2): both uploaders stop
before anything is sent, with one line naming both addresses and exit status 2.

Before: MAVSDK followed system 1 wherever it was heard and uploaded to one of two mocks,
reporting "identical"; the pymavlink client stopped only if the second HEARTBEAT came while the
upload was still running.
"""

from __future__ import annotations

import importlib.util
import re
import threading
import time

import pytest

from lamde_mission.cli import main
from lamde_mission.items import MISSION_TYPE
from lamde_mission.vehicle.claims import HEARTBEAT_WATCH_S, ClaimWatch
from lamde_mission.vehicle.transfer import DuplicateVehicleError
from lamde_mission.vehicle.upload import upload_mission
from tests.vehicle_helpers import (  # noqa: F401 - the autouse fixture
    free_udp_port,
    hand_mission,
    listen_on,
    mock_on,
    no_leftover_mock_threads,
)

#: these tests exercise and time the watch itself (`claims.HEARTBEAT_WATCH_S`)
pytestmark = pytest.mark.full_watch

HAS_MAVSDK = importlib.util.find_spec("mavsdk") is not None
NO_MAVSDK = pytest.mark.skipif(not HAS_MAVSDK, reason="mavsdk is not installed")
VIAS = ["pymavlink", pytest.param("mavsdk", marks=NO_MAVSDK)]


@pytest.fixture
def port() -> int:
    return free_udp_port()


def _plan_file(tmp_path):
    from tests.test_altitudes import good_items, write

    return write(tmp_path, good_items(), ".plan")


@pytest.mark.parametrize("via", VIAS)
@pytest.mark.slow  # measured 2.3 s on a loaded machine (default suite <= 5 min)
def test_two_mocks_claiming_system_1_are_refused_before_sending(port, tmp_path, capsys,
                                                                via) -> None:  # fmt: skip
    """One mock at 4 Hz, the other at a real autopilot's 1 Hz (the watch must cover a whole
    period of the slower one): exit 1 (the link failed; it was 2, as for bad input), one line
    on stderr naming both mocks' addresses, nothing on stdout, neither mock sent a single
    item."""
    path = _plan_file(tmp_path)
    with mock_on(port) as a, mock_on(port, heartbeat_hz=1.0) as b:
        t0 = time.monotonic()
        rc = main(["upload", str(path), "--via", via, "--connect", listen_on(port),
                   "--timeout", "10"])  # fmt: skip
        took = time.monotonic() - t0
        uploads = a.stats.uploads[MISSION_TYPE.MISSION] + b.stats.uploads[MISSION_TYPE.MISSION]
        addrs = {f"{h}:{p}" for h, p in (a.address, b.address)}
    out = capsys.readouterr()
    assert rc == 1, out
    assert out.out == "" and len(out.err.splitlines()) == 1, out
    line = out.err.strip()
    assert line.startswith("lamde-mission upload: two autopilots claim system 1 component 1: ")
    assert "nothing was sent" in line
    named = set(re.findall(r"127\.0\.0\.1:\d+", line))
    assert named == addrs, (named, addrs)
    assert uploads == 0
    assert took < 10, took  # stopped by the watch, not by a time-out


@pytest.mark.parametrize("via", VIAS)
@pytest.mark.slow  # measured 2.6 s on a loaded machine (default suite <= 5 min)
def test_one_mock_uploads_after_the_watch(port, via) -> None:
    """A single vehicle: the upload goes through, after at least the heartbeat watch."""
    mission = hand_mission(3)
    with mock_on(port) as v:
        t0 = time.monotonic()
        report = upload_mission(mission, [], connect=listen_on(port), via=via, timeout=10,
                                attempts=1)  # fmt: skip
        took = time.monotonic() - t0
        assert len(v.items()) == len(mission)
    assert report.ok and took >= HEARTBEAT_WATCH_S * 0.95, took


@pytest.mark.parametrize("via", VIAS)
@pytest.mark.slow  # measured 1.4 s on a loaded machine (default suite <= 5 min)
def test_a_second_claim_mid_session_stops_it(port, via) -> None:
    """A second autopilot with the vehicle's ids that starts after the watch (here: the watch
    set to 0 s) still stops the session, naming both addresses; `sent` tells which wording."""
    mission = hand_mission(60)
    with mock_on(port, latency_ms=30.0) as a:
        late = mock_on(port, heartbeat_hz=20.0)
        late_port = late.address[1]
        timer = threading.Timer(0.6, late.start)
        try:
            timer.start()
            with pytest.raises(DuplicateVehicleError) as info:
                upload_mission(mission, [], connect=listen_on(port), via=via, timeout=10,
                               attempts=1, heartbeat_watch=0.0)  # fmt: skip
        finally:
            timer.join()
            late.stop()
        msg = str(info.value)
        assert f"the one pinned at 127.0.0.1:{a.address[1]}" in msg
        assert f"another at 127.0.0.1:{late_port}" in msg
        assert "; stopped, since" in msg


def test_the_watch_records_addresses_per_id() -> None:
    from pymavlink.dialects.v20 import common as mavlink2

    def hb(sysid: int, comp: int, autopilot: int = mavlink2.MAV_AUTOPILOT_PX4):
        mav = mavlink2.MAVLink(None, srcSystem=sysid, srcComponent=comp)
        msg = mavlink2.MAVLink_heartbeat_message(2, autopilot, 0, 0, 3, 3)
        return mav.decode(bytearray(msg.pack(mav)))

    w = ClaimWatch(1.0, clock=lambda: 10.0)
    assert w.ends_at() == 11.0
    a, b = ("127.0.0.1", 1), ("127.0.0.1", 2)
    assert w.note(hb(1, 1), a) and not w.note(hb(1, 1), a)
    assert not w.note(hb(1, 1, mavlink2.MAV_AUTOPILOT_INVALID), b)  # a GCS, not an autopilot
    assert not w.note(hb(1, 1), None)  # a serial link: one sender
    assert w.note(hb(2, 1), b)  # another system: no conflict for system 1
    assert w.conflict((1, 1), a) is None and w.conflict((1, 1), None) is None
    assert w.note(hb(1, 1), b)
    assert w.conflict((1, 1), a) == b and w.conflict((1, 1), b) == a
    with pytest.raises(ValueError, match="heartbeat watch"):
        ClaimWatch(-1.0)

"""The mock vehicle's MAVLink behaviour message by message, and the wire conversions."""

from __future__ import annotations

import math
import threading
import time
from dataclasses import replace

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from lamde_mission.items import CMD, FRAME, MISSION_TYPE, MissionItem
from lamde_mission.vehicle.mock import CAPABILITIES, UPLOAD_TIMING, MockVehicle
from lamde_mission.vehicle.wire import (
    INT32_MAX,
    Endpoint,
    WireItem,
    compare_items,
    from_wire,
    mission_result_code,
    mission_result_name,
    parse_endpoint,
    to_wire,
    wire_mission,
)
from tests.vehicle_helpers import RawGcs, free_udp_port, hand_fence, hand_mission

m = mavlink2
FENCE = MISSION_TYPE.FENCE


@pytest.fixture
def link():
    """(mock, raw ground station) on a fresh port; the GCS has heard the first heartbeat."""
    port = free_udp_port()
    with RawGcs(port) as gcs, MockVehicle(f"udpout:127.0.0.1:{port}") as v:
        hb = gcs.wait("HEARTBEAT", 2.0)
        assert hb is not None
        yield v, gcs


def _item_msg(w: WireItem):
    return m.MAVLink_mission_item_int_message(1, 1, *w.fields())


# ----------------------------------------------------------------------------- identity


@pytest.mark.slow  # measured 2.0 s on a loaded machine (default suite <= 5 min)
def test_heartbeat_identity_and_rate(link):
    v, gcs = link
    hb = gcs.wait("HEARTBEAT", 1.5)
    assert hb.get_srcSystem() == 1 and hb.get_srcComponent() == 1
    assert hb.type == m.MAV_TYPE_QUADROTOR and hb.autopilot == m.MAV_AUTOPILOT_PX4
    t0 = time.monotonic()
    assert gcs.wait("HEARTBEAT", 1.5) is not None
    assert 0.8 < time.monotonic() - t0 < 1.2  # 1 Hz


@pytest.mark.parametrize("how", ["capabilities", "request_message"])
def test_autopilot_version_on_request(link, how):
    v, gcs = link
    if how == "capabilities":
        cmd, p1 = m.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1
    else:
        cmd, p1 = m.MAV_CMD_REQUEST_MESSAGE, m.MAVLINK_MSG_ID_AUTOPILOT_VERSION
    gcs.send(m.MAVLink_command_long_message(1, 1, cmd, 0, p1, 0, 0, 0, 0, 0, 0))
    ack = gcs.wait("COMMAND_ACK", command=cmd)
    assert ack.result == m.MAV_RESULT_ACCEPTED
    av = gcs.wait("AUTOPILOT_VERSION")
    for bit in (m.MAV_PROTOCOL_CAPABILITY_MISSION_INT, m.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE,
                m.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY):  # fmt: skip
        assert av.capabilities & bit
    assert av.capabilities == CAPABILITIES


def test_unknown_command_is_acked_unsupported(link):
    v, gcs = link
    gcs.send(m.MAVLink_command_long_message(1, 1, m.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1,
                                            0, 0, 0, 0, 0, 0))  # fmt: skip
    ack = gcs.wait("COMMAND_ACK", command=m.MAV_CMD_COMPONENT_ARM_DISARM)
    assert ack.result == m.MAV_RESULT_UNSUPPORTED


def test_messages_for_another_system_are_ignored(link):
    v, gcs = link
    gcs.send(m.MAVLink_mission_count_message(7, 1, 3, 0))
    assert gcs.wait("MISSION_REQUEST_INT", 0.3) is None


# ----------------------------------------------------------------------------- upload


@pytest.mark.parametrize("mission_type", [MISSION_TYPE.MISSION, FENCE, MISSION_TYPE.RALLY])
def test_upload_then_download_each_mission_type(link, mission_type):
    v, gcs = link
    items = wire_mission(hand_mission(1) if mission_type == 0 else hand_fence())
    items = [WireItem(*w.fields()[:-1], mission_type) for w in items]
    gcs.send(m.MAVLink_mission_count_message(1, 1, len(items), mission_type))
    for w in items:
        req = gcs.wait("MISSION_REQUEST_INT", mission_type=mission_type)
        assert req.seq == w.seq
        gcs.send(_item_msg(w))
    ack = gcs.wait("MISSION_ACK", mission_type=mission_type)
    assert ack.type == m.MAV_MISSION_ACCEPTED
    assert compare_items(items, v.wire_items(mission_type)) == []
    # download, with the older MISSION_REQUEST for one item
    gcs.send(m.MAVLink_mission_request_list_message(1, 1, mission_type))
    assert gcs.wait("MISSION_COUNT", mission_type=mission_type).count == len(items)
    got = []
    for seq in range(len(items)):
        request = m.MAVLink_mission_request_int_message
        if seq == 1:
            request = m.MAVLink_mission_request_message
        gcs.send(request(1, 1, seq, mission_type))
        msg = gcs.wait("MISSION_ITEM_INT", seq=seq)
        assert msg.mission_type == mission_type
        got.append(WireItem(*(getattr(msg, f) for f in WireItem.__dataclass_fields__)))
    gcs.send(m.MAVLink_mission_ack_message(1, 1, m.MAV_MISSION_ACCEPTED, mission_type))
    assert compare_items(items, got) == []
    assert [g.x for g in got] == [w.x for w in items]


@pytest.mark.parametrize("autopilot", ["px4", "ardupilot"])
def test_vehicle_rerequests_a_missing_item_as_its_autopilot_does(autopilot):
    """PX4 asks again 250 ms after its last request, ArduPilot 1 s after (UPLOAD_TIMING)."""
    period, give_up = UPLOAD_TIMING[autopilot]
    port = free_udp_port()
    with RawGcs(port) as gcs, MockVehicle(f"udpout:127.0.0.1:{port}", autopilot=autopilot) as v:
        assert gcs.wait("HEARTBEAT", 2.0) is not None
        assert (v.rerequest_s, v.give_up_s) == (period, give_up)
        gcs.send(m.MAVLink_mission_count_message(1, 1, 2, 0))
        first = gcs.wait("MISSION_REQUEST_INT", seq=0)
        t0 = time.monotonic()
        again = gcs.wait("MISSION_REQUEST_INT", period + 1.0, seq=0)  # item 0 "lost": again
        assert first is not None and again is not None
        assert time.monotonic() - t0 >= period - 0.05  # not before the autopilot's period
        assert v.stats.rerequests >= 1


def test_vehicle_gives_up_a_silent_upload():
    """Silence for `give_up_s`: the upload is dropped with MAV_MISSION_OPERATION_CANCELLED and
    the stored list is left as it was."""
    port = free_udp_port()
    with RawGcs(port) as gcs, MockVehicle(f"udpout:127.0.0.1:{port}", give_up_s=0.6) as v:
        assert gcs.wait("HEARTBEAT", 2.0) is not None
        gcs.send(m.MAVLink_mission_count_message(1, 1, 2, 0))
        ack = gcs.wait("MISSION_ACK", 5.0)
        assert ack is not None and ack.type == m.MAV_MISSION_OPERATION_CANCELLED
        assert v.items() == [] and v.stats.rerequests >= 1


@pytest.mark.parametrize(("autopilot", "answer"), [("px4", m.MAV_MISSION_ACCEPTED),
                                                   ("ardupilot", m.MAV_MISSION_ERROR)])
def test_a_resent_last_item_after_the_final_ack(autopilot, answer):
    """PX4 ACKs a repeat of the last item again (its final ACK was lost); ArduPilot, no longer
    receiving, answers MAV_MISSION_ERROR (GCS_Common.cpp)."""
    port = free_udp_port()
    with RawGcs(port) as gcs, MockVehicle(f"udpout:127.0.0.1:{port}", autopilot=autopilot) as v:
        assert gcs.wait("HEARTBEAT", 2.0) is not None
        items = wire_mission(hand_mission(0))
        gcs.send(m.MAVLink_mission_count_message(1, 1, len(items), 0))
        for w in items:
            gcs.wait("MISSION_REQUEST_INT", seq=w.seq)
            gcs.send(_item_msg(w))
        assert gcs.wait("MISSION_ACK").type == m.MAV_MISSION_ACCEPTED
        gcs.send(_item_msg(items[-1]))  # "the ACK never came"
        assert gcs.wait("MISSION_ACK").type == answer
        assert v.stats.uploads[0] == 1


@pytest.mark.parametrize("autopilot", ["px4", "ardupilot"])
@pytest.mark.slow  # measured 1.7 s on a loaded machine (default suite <= 5 min)
def test_an_item_out_of_turn_leaves_the_upload_going(autopilot):
    """PX4 ignores an item it did not ask for, ArduPilot answers MAV_MISSION_INVALID_SEQUENCE;
    both ask again for the item they miss, and the upload completes."""
    port = free_udp_port()
    with RawGcs(port) as gcs, MockVehicle(f"udpout:127.0.0.1:{port}", autopilot=autopilot) as v:
        assert gcs.wait("HEARTBEAT", 2.0) is not None
        items = wire_mission(hand_mission(2))
        gcs.send(m.MAVLink_mission_count_message(1, 1, len(items), 0))
        assert gcs.wait("MISSION_REQUEST_INT", seq=0) is not None
        gcs.send(_item_msg(items[2]))  # a skip
        gcs.send(_item_msg(items[0]))
        assert gcs.wait("MISSION_REQUEST_INT", seq=1) is not None
        gcs.send(_item_msg(items[0]))  # a duplicate
        ack = gcs.wait("MISSION_ACK", 0.5)
        if autopilot == "ardupilot":
            assert ack is not None and ack.type == m.MAV_MISSION_INVALID_SEQUENCE
        else:
            assert ack is None
        assert gcs.wait("MISSION_REQUEST_INT", 2.0, seq=1) is not None  # asked again
        for w in items[1:]:
            gcs.send(_item_msg(w))
            if w.seq < len(items) - 1:
                assert gcs.wait("MISSION_REQUEST_INT", 2.0, seq=w.seq + 1) is not None
        assert gcs.wait("MISSION_ACK", 2.0).type == m.MAV_MISSION_ACCEPTED
        assert v.stats.uploads[0] == 1 and len(v.wire_items()) == len(items)


def test_request_past_the_end_is_an_invalid_sequence(link):
    v, gcs = link
    v.set_items(hand_mission(0))
    gcs.send(m.MAVLink_mission_request_int_message(1, 1, 9, 0))
    ack = gcs.wait("MISSION_ACK")
    assert ack.type == m.MAV_MISSION_INVALID_SEQUENCE and ack.mission_type == 0


@pytest.mark.parametrize(
    "msg",
    [m.MAVLink_mission_count_message(1, 1, 2, 7), m.MAVLink_mission_request_list_message(1, 1, 7),
     m.MAVLink_mission_clear_all_message(1, 1, 7)],
)  # fmt: skip
def test_unsupported_mission_type(link, msg):
    v, gcs = link
    gcs.send(msg)
    ack = gcs.wait("MISSION_ACK")
    assert ack.type == m.MAV_MISSION_UNSUPPORTED and ack.mission_type == 7


def test_too_many_items_is_no_space():
    port = free_udp_port()
    with RawGcs(port) as gcs, MockVehicle(f"udpout:127.0.0.1:{port}", max_items=10):
        gcs.wait("HEARTBEAT")
        gcs.send(m.MAVLink_mission_count_message(1, 1, 11, 0))
        assert gcs.wait("MISSION_ACK").type == m.MAV_MISSION_NO_SPACE


def test_reject_option_refuses_every_upload():
    port = free_udp_port()
    with RawGcs(port) as gcs, MockVehicle(f"udpout:127.0.0.1:{port}", reject=14) as v:
        assert v.reject == m.MAV_MISSION_DENIED
        gcs.wait("HEARTBEAT")
        gcs.send(m.MAVLink_mission_count_message(1, 1, 3, FENCE))
        ack = gcs.wait("MISSION_ACK")
        assert (ack.type, ack.mission_type) == (m.MAV_MISSION_DENIED, FENCE)


def test_clear_all(link):
    v, gcs = link
    v.set_items(hand_mission(1))
    v.set_items(hand_fence(), FENCE)
    gcs.send(m.MAVLink_mission_clear_all_message(1, 1, FENCE))
    assert gcs.wait("MISSION_ACK").type == m.MAV_MISSION_ACCEPTED
    assert v.items(FENCE) == [] and len(v.items()) == 5
    gcs.send(m.MAVLink_mission_clear_all_message(1, 1, m.MAV_MISSION_TYPE_ALL))
    assert gcs.wait("MISSION_ACK").type == m.MAV_MISSION_ACCEPTED
    assert v.items() == []


def test_empty_upload_clears_and_empty_download_is_a_zero_count(link):
    v, gcs = link
    v.set_items(hand_mission(1))
    gcs.send(m.MAVLink_mission_count_message(1, 1, 0, 0))
    assert gcs.wait("MISSION_ACK").type == m.MAV_MISSION_ACCEPTED
    gcs.send(m.MAVLink_mission_request_list_message(1, 1, 0))
    assert gcs.wait("MISSION_COUNT").count == 0


def test_loss_is_seeded_and_counted():
    port = free_udp_port()
    with RawGcs(port) as gcs:
        with MockVehicle(f"udpout:127.0.0.1:{port}", loss=0.5, seed=4, heartbeat_hz=50) as v:
            time.sleep(0.5)
        assert 0 < v.stats.dropped < v.stats.sent
        heard = 0
        while gcs.wait("HEARTBEAT", 0.05) is not None:
            heard += 1
        assert heard == v.stats.sent - v.stats.dropped


def _drop_pattern(v: MockVehicle, n: int = 200) -> tuple[list[bool], list[bool]]:
    """Which of n HEARTBEATs `v` loses on the way out and which of n datagrams on the way in
    (its loss draws in order, without timing)."""
    out, inn = [], []
    for _ in range(n):
        sent, got = v.stats.dropped, v.stats.dropped_in
        v._send_heartbeat()
        v._datagram(b"", ("127.0.0.1", 9))
        out.append(v.stats.dropped > sent)
        inn.append(v.stats.dropped_in > got)
    return out, inn


def test_the_default_seed_drops_the_same_messages_every_run():
    runs = []
    for _ in range(2):
        v = MockVehicle(f"udpout:127.0.0.1:{free_udp_port()}", loss=0.5, loss_in=0.5)
        try:
            runs.append(_drop_pattern(v))
        finally:
            v.stop()
    (out, inn), again = runs
    assert (out, inn) == again
    assert 0 < sum(out) < len(out) and 0 < sum(inn) < len(inn)


def test_the_default_seed_gives_each_fleet_vehicle_the_same_losses_every_run():
    from lamde_mission.vehicle.mock_fleet import MockFleet

    runs = []
    for _ in range(2):
        fleet = MockFleet(f"udpout:127.0.0.1:{free_udp_port()}", vehicles=2, loss=0.5,
                          loss_in=0.5)
        try:
            runs.append([_drop_pattern(v) for v in fleet.vehicles])
        finally:
            fleet.stop()
    assert runs[0] == runs[1]
    assert runs[0][0] != runs[0][1]  # vehicle k draws from seed + k


def test_mock_vehicle_seed_defaults_to_0():
    from lamde_mission.cli import build_parser

    assert build_parser().parse_args(["mock-vehicle"]).seed == 0


def test_latency_delays_outgoing_messages():
    port = free_udp_port()
    with RawGcs(port) as gcs, MockVehicle(f"udpout:127.0.0.1:{port}", latency_ms=200) as v:
        gcs.wait("HEARTBEAT", 1.0)
        t0 = time.monotonic()
        gcs.send(m.MAVLink_mission_request_list_message(1, 1, 0))
        assert gcs.wait("MISSION_COUNT", 2.0) is not None
        assert time.monotonic() - t0 >= 0.19
        assert v.rerequest_s >= 0.4  # re-requests wait for a round trip


def test_stop_closes_the_socket_and_is_idempotent():
    v = MockVehicle(f"udpout:127.0.0.1:{free_udp_port()}").start()
    host, port = v.address
    assert host == "127.0.0.1" and port > 0
    v.stop()
    v.stop()
    assert not any(t.name == "mock-vehicle" for t in threading.enumerate())
    with pytest.raises(RuntimeError):
        _ = v.address


@pytest.mark.parametrize("kw", [{"loss": 1.0}, {"loss": -0.1}, {"latency_ms": -1},
                                {"reject": "NOPE"}, {"reject": 99}])  # fmt: skip
def test_bad_mock_options(kw):
    with pytest.raises(ValueError):
        MockVehicle(f"udpout:127.0.0.1:{free_udp_port()}", **kw)


# ----------------------------------------------------------------------------- wire


def test_to_wire_conversions():
    it = MissionItem(5, CMD.LOITER_TIME, FRAME.GLOBAL_RELATIVE_ALT, param1=0.1, param4=math.nan,
                     x=-35.36321234567, y=149.16521234567, z=90.123456789)  # fmt: skip
    w = to_wire(it, seq=0, current=1)
    assert (w.seq, w.current) == (0, 1)
    assert (w.x, w.y) == (-353632123, 1491652123)
    assert w.param1 == float(np.float32(0.1)) != 0.1
    assert math.isnan(w.param4)
    back = from_wire(w)
    assert abs(back.x - it.x) <= 0.5e-7 and abs(back.y - it.y) <= 0.5e-7
    # DO commands: params 5/6 are plain integers; NaN lat/lon travel as INT32_MAX
    do = to_wire(MissionItem(0, CMD.DO_CHANGE_SPEED, FRAME.MISSION, x=3.0, y=-2.0))
    assert (do.x, do.y) == (3, -2)
    nan = to_wire(MissionItem(0, CMD.WAYPOINT, x=math.nan, y=math.nan))
    assert nan.x == nan.y == INT32_MAX and math.isnan(from_wire(nan).x)


def test_to_wire_refuses_what_mavlink_cannot_carry():
    with pytest.raises(ValueError, match="float32"):
        to_wire(MissionItem(0, CMD.WAYPOINT, param1=1e39))
    with pytest.raises(ValueError, match="int32"):
        to_wire(MissionItem(0, CMD.WAYPOINT, FRAME.MISSION, x=3e9))
    with pytest.raises(ValueError, match="one mission type"):
        wire_mission(hand_mission(0) + hand_fence())


def test_compare_items_tolerance_and_fields():
    a = hand_mission(1)
    b = list(a)
    b[2] = replace(b[2], x=b[2].x + 0.9e-7)  # within the int rounding
    assert compare_items(a, b) == []
    b[2] = replace(b[2], x=b[2].x + 3e-7, param1=1.0)
    diffs = compare_items(a, b)
    assert [(d.index, d.field) for d in diffs] == [(2, "param1"), (2, "x")]
    assert "mission item 2: param1 sent" in str(diffs[0])
    b[0] = replace(b[0], current=1)  # current is not compared
    assert len(compare_items(a, b)) == 2
    assert [(d.index, d.field) for d in compare_items(a, b[:-1])][0] == (None, "count")
    nan_vs_zero = compare_items([a[0]], [replace(a[0], param4=0.0)])
    assert [d.field for d in nan_vs_zero] == ["param4"]


def test_endpoints_and_result_names():
    assert parse_endpoint("udpin://0.0.0.0:14540") == Endpoint("udpin", "0.0.0.0", 14540)
    assert parse_endpoint("udpout:127.0.0.1:14550") == Endpoint("udpout", "127.0.0.1", 14550)
    assert parse_endpoint("udp::14540") == Endpoint("udpin", "0.0.0.0", 14540)
    assert parse_endpoint("udpin:127.0.0.1:1").url() == "udpin://127.0.0.1:1"
    for bad in ("tcp:1.2.3.4:5", "udpin://host", "udpout:127.0.0.1:0", "serial:/dev/ttyS0"):
        with pytest.raises(ValueError):
            parse_endpoint(bad)
    assert mission_result_code("NO_SPACE") == mission_result_code("mav_mission_no_space") == 4
    assert mission_result_code("13") == mission_result_code(13) == m.MAV_MISSION_INVALID_SEQUENCE
    assert mission_result_name(4) == "MAV_MISSION_NO_SPACE"


def test_a_download_request_ends_an_abandoned_upload(link):
    v, gcs = link
    v.set_items(hand_mission(0))
    items = wire_mission(hand_mission(2))
    gcs.send(m.MAVLink_mission_count_message(1, 1, len(items), 0))
    gcs.wait("MISSION_REQUEST_INT", seq=0)
    gcs.send(_item_msg(items[0]))  # ... and the ground station gives up without a word
    gcs.send(m.MAVLink_mission_request_list_message(1, 1, 0))
    assert gcs.wait("MISSION_COUNT", mission_type=0).count == 4  # the old mission, whole
    gcs.send(m.MAVLink_mission_request_int_message(1, 1, 0, 0))
    assert gcs.wait("MISSION_ITEM_INT", seq=0) is not None

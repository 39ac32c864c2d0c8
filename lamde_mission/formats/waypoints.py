"""ArduPilot / Mission Planner `.waypoints` files (the plain-text "QGC WPL 110" format).

One header line, then one tab-separated line per item:
``seq current frame command p1 p2 p3 p4 lat lon alt autocontinue``. Line 0 is the home
position (ArduPilot convention: MAV_CMD_NAV_WAYPOINT, frame GLOBAL, altitude AMSL, current 1);
our items follow as seq 1..N. The reader drops that home line (only when row 0 is one) and
numbers items from 0 again, DO_JUMP targets with them. Our own missions carry no DO_JUMP; a
written DO_JUMP targets the row number (home = 0), as Mission Planner writes it.

NaN parameters (our "keep yaw" values) are written as 0: the text format has no NaN that every
reader accepts, and ArduPilot ignores the yaw parameter of TAKEOFF, WAYPOINT and LAND. Numbers
are written in the shortest form that reads back to the same float. The format holds no fence.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from lamde_mission.atomic import write_text_atomic
from lamde_mission.formats.ranges import check_item_count, check_mission_item
from lamde_mission.items import CMD, FRAME, MISSION_TYPE, MissionError, MissionItem
from planner_core.textio import limit, quoted
from sim.mission import command_name

__all__ = ["HEADER", "format_waypoints", "parse_waypoints", "write_waypoints", "is_home_row",
           "check_mission_list"]

HEADER = "QGC WPL 110"


def _num(v: float) -> str:
    v = float(v)
    if math.isnan(v):
        v = 0.0
    if math.isinf(v):
        raise ValueError("infinite parameter cannot be written to a .waypoints file")
    return np.format_float_positional(v, unique=True, trim="0")


def _line(seq: int, it: MissionItem) -> str:
    fields = [str(seq), str(int(it.current)), str(int(it.frame)), str(int(it.command))]
    fields += [_num(p) for p in it.params]
    fields.append(str(int(it.autocontinue)))
    return "\t".join(fields)


def format_waypoints(items: Sequence[MissionItem], home: tuple[float, float, float]) -> str:
    """The file text: header, home line (lat, lon, altitude AMSL), then the items as 1..N.

    Args:
        items: the mission items; a DO_JUMP's param1 is written as the target's row (+1).
        home: (lat, lon, alt) of the home line: degrees, degrees, metres AMSL.

    Returns:
        The text, tab-separated, one line per row, ending with a newline.

    Raises:
        ValueError: an infinite parameter (NaN is written as 0).
    """
    home_item = MissionItem(
        seq=0, command=CMD.WAYPOINT, frame=FRAME.GLOBAL, current=1, autocontinue=1,
        x=float(home[0]), y=float(home[1]), z=float(home[2]),
    )  # fmt: skip
    lines = [HEADER, _line(0, home_item)]
    # DO_JUMP targets are row numbers in the file (home = row 0)
    lines += [_line(k + 1, replace(it, param1=it.param1 + 1) if it.command == CMD.DO_JUMP else it)
              for k, it in enumerate(items)]  # fmt: skip
    return "\n".join(lines) + "\n"


#: the column names used in messages ("line 5: param1")
_WPL_NAMES = {"x": "latitude", "y": "longitude", "z": "altitude"}


#: the 12 columns of an item line, for messages
_COLUMNS = ("seq", "current", "frame", "command", "param1", "param2", "param3", "param4",
            "latitude", "longitude", "altitude", "autocontinue")  # fmt: skip
#: ASCII only: Python's int() and float() also read "1_00", "١٠٠" (Arabic-Indic digits) and
#: other Unicode digits, which no autopilot's parser does
_INT_RE = re.compile(r"[+-]?[0-9]{1,20}")
_FLOAT_RE = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
                       r"|[+-]?(?:nan|inf|infinity)", re.IGNORECASE)  # fmt: skip


def _int(s: str) -> int:
    """An integer field: ASCII digits, at most 20 (Python refuses long ones slowly or not at
    all); ValueError otherwise."""
    if not _INT_RE.fullmatch(s):
        raise ValueError(s)
    return int(s)


def _float(s: str) -> float:
    """A number field: an ASCII decimal number (or nan/inf, which the range checks judge);
    ValueError otherwise."""
    if len(s) > 400 or not _FLOAT_RE.fullmatch(s):
        raise ValueError(s)
    return float(s)


def _numbers(a: list[str], lineno: int) -> tuple[list[int], list[float]]:
    """The integer and number columns of one item line; MissionError naming the column."""
    ints, floats = [], []
    for i, v in enumerate(a):
        is_int = i in (0, 1, 2, 3, 11)
        try:
            (ints if is_int else floats).append(_int(v) if is_int else _float(v))
        except ValueError:
            shown = ascii(v[:20]) + ("..." if len(v) > 20 else "")
            want = ("an integer (at most 20 ASCII digits)" if is_int
                    else "a number (ASCII digits, no underscores)")  # fmt: skip
            raise MissionError(f"line {lineno}: {_COLUMNS[i]}: {shown} is not {want}") from None
    return ints, floats  # ints: seq, current, frame, command, autocontinue


#: the line boundaries `str.splitlines` splits at besides CR and LF (a CR LF pair is one)
_OTHER_BREAKS = "\v\f\x1c\x1d\x1e\x85\u2028\u2029"


def _line_breaks(text: str) -> int:
    """The line boundaries of `text` as `str.splitlines` splits at them (CR LF, LF, a lone CR,
    ...), counted without splitting: O(len(text)) time, O(1) memory."""
    n = text.count("\n") + text.count("\r") - text.count("\r\n")
    return n + sum(text.count(c) for c in _OTHER_BREAKS)


def parse_waypoints(text: str) -> tuple[MissionItem | None, list[MissionItem]]:
    """(home item, mission items numbered from 0) of `.waypoints` text; MissionError if bad.

    Row 0 is dropped as the home line only when it is one (`is_home_row`), and DO_JUMP targets
    (row numbers) are then renumbered to the list without it. The home item is None when the
    file has no home line. A UTF-8 byte-order mark is accepted. Fence or rally commands
    (5000-5004, 5100) in the list are refused: the file format holds a mission only.

    Args:
        text: the file's text.

    Returns:
        (home, items): the home item or None, and the mission items with seq 0..N-1.

    Raises:
        MissionError: a bad header, line, field, sequence number or DO_JUMP target, too many
            lines or items, no items, or a fence or rally command (naming the line or row).
    """
    # a line per item, a home line, and room for blank or comment lines: refuse a huge file
    # before splitting it
    cap = limit("mission_items")
    n = _line_breaks(text)
    if n > 2 * (cap + 1):
        raise MissionError(f"{n:,} lines, far more than the {cap:,} items "
                           "MAVLink can number (seq and count are uint16)")  # fmt: skip
    lines = text.removeprefix("\ufeff").splitlines()
    if not lines or lines[0].strip() != HEADER:
        found = lines[0].strip()[:40] if lines else ""
        raise MissionError(f"not a '{HEADER}' waypoint file (first line is {quoted(found)})")
    rows: list[MissionItem] = []
    for lineno, line in enumerate(lines[1:], start=2):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        a = s.split()
        if len(a) != 12:
            raise MissionError(f"line {lineno}: expected 12 values, got {len(a)}")
        ints, floats = _numbers(a, lineno)
        if not -(2**31) <= ints[0] < 2**31:
            raise MissionError(f"line {lineno}: seq {ints[0]} is not a sequence number")
        seq, current, frame, command, autocontinue = ints
        if seq != len(rows):  # DO_JUMP targets and the vehicle count rows by their seq
            raise MissionError(f"line {lineno}: seq {seq} out of order (rows are numbered 0, "
                               f"1, 2, ... in file order; expected {len(rows)})")  # fmt: skip
        item = (
            MissionItem(
                seq=seq, command=command, frame=frame, current=current,
                autocontinue=autocontinue, param1=floats[0], param2=floats[1],
                param3=floats[2], param4=floats[3], x=floats[4], y=floats[5], z=floats[6],
                mission_type=MISSION_TYPE.MISSION,
            )
        )  # fmt: skip
        check_mission_item(item, lambda f, n=lineno: f"line {n}: {_WPL_NAMES.get(f, f)}")
        rows.append(item)
        check_item_count(len(rows) - 1, "the file")
    if not rows:
        raise MissionError("the file holds no items (not even the home line)")
    if not is_home_row(rows[0]):
        # no home line (a file another tool wrote): row 0 is a mission item and is kept
        check_mission_list(rows, "row")
        return None, [it.with_seq(k) for k, it in enumerate(rows)]
    home, items = rows[0], rows[1:]
    check_mission_list(items, "row")
    out = []
    for k, it in enumerate(items):
        if it.command == CMD.DO_JUMP:
            # targets count rows (home = row 0); the list without the home row starts at 0
            target = int(it.param1) if math.isfinite(it.param1) else -1
            if target < 1 or target > len(items):
                raise MissionError(f"row {it.seq}: DO_JUMP targets row {target}, not a mission "
                                   "item of this file")  # fmt: skip
            it = replace(it, param1=float(target - 1))
        out.append(it.with_seq(k))
    return home, out


def is_home_row(it: MissionItem) -> bool:
    """Row 0 of a `.waypoints` file is the home position when it is a NAV_WAYPOINT in an
    absolute-altitude global frame (what Mission Planner and ArduPilot write there).

    Args:
        it: a row of the file.

    Returns:
        True when `it` has seq 0, command NAV_WAYPOINT and frame GLOBAL or GLOBAL_INT.
    """
    return int(it.seq) == 0 and it.command == CMD.WAYPOINT and it.frame in (
        FRAME.GLOBAL, FRAME.GLOBAL_INT)


def write_waypoints(
    path: str | Path, items: Sequence[MissionItem], home: tuple[float, float, float]
) -> Path:
    """Write a `.waypoints` file atomically.

    Args:
        path: the file to write.
        items: the mission items (`format_waypoints`).
        home: (lat, lon, alt) of the home line: degrees, degrees, metres AMSL.

    Returns:
        The path written.

    Raises:
        ValueError: an infinite parameter.
    """
    return write_text_atomic(path, format_waypoints(items, home))


def check_mission_list(items: Sequence[MissionItem], what: str = "item") -> None:
    """Refuse fence and rally commands in a mission list: sent as mission items they would
    replace the vehicle's mission with fence vertices.

    Args:
        items: the mission list.
        what: the word for an entry in the message ("item", "row").

    Raises:
        MissionError: the first fence or rally command, naming its row (`what` and seq).
    """
    for it in items:
        if it.command in CMD.FENCE_COMMANDS or it.command == CMD.RALLY_POINT:
            kind = "rally" if it.command == CMD.RALLY_POINT else "fence"
            raise MissionError(
                f"{what} {it.seq}: {command_name(it.command)} ({it.command}) is a {kind} item, "
                f"not a mission item; a mission list cannot carry it (put fences and rally "
                "points in a QGroundControl .plan)"
            )

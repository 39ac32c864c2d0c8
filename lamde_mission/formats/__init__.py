"""Mission files: QGroundControl `.plan`, ArduPilot `.waypoints`, GeoJSON (export only).

`write_mission` picks the format from the suffix (or `fmt`); `read_mission` recognises a file
by its content (a `.plan` JSON object or a "QGC WPL 110" text), whatever its suffix.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any, Literal

from lamde_mission.geo import enu_to_latlon
from lamde_mission.items import CMD, MissionError, MissionItem, geofence_items, plan_to_items
from lamde_mission.storage import DIALECTS, float32, float32_up, grid_degrees, stored_items
from planner_core.textio import InputError, loads_json, printable, quoted, read_json, read_text

__all__ = [
    "FORMATS",
    "MissionFileError",
    "format_for",
    "write_mission",
    "read_mission",
    "read_mission_lists",
    "load_mission_items",
    "home_of",
]

#: suffix -> format name
FORMATS = {".plan": "plan", ".waypoints": "waypoints", ".geojson": "geojson"}

#: format name -> what its files hold (for the messages)
FORMAT_TEXT = {"plan": "QGroundControl JSON", "waypoints": "QGC WPL text",
               "geojson": "GeoJSON"}  # fmt: skip


class MissionFileError(ValueError):
    """A mission file that cannot be read or written (message names the file)."""


def format_for(path: str | Path, fmt: str | None = None) -> str:
    """The format name for `path` ("plan", "waypoints", "geojson").

    Args:
        path: the mission file; its suffix (.plan, .waypoints, .geojson, any case) names the
            format.
        fmt: a format name ("plan", "waypoints", "geojson"; case and a leading dot ignored,
            "json" read as "geojson"): for a `path` without one of those suffixes (e.g.
            mission.txt), or the suffix's own format.

    Returns:
        "plan", "waypoints" or "geojson".

    Raises:
        MissionFileError: an unknown `fmt`; a `fmt` that disagrees with a known suffix (a
            .plan file that is not QGroundControl JSON would not open in QGroundControl);
            without `fmt`, an unknown suffix.
    """
    suffix = Path(path).suffix.lower()
    if fmt is not None:
        f = fmt.lower().lstrip(".")
        if f == "json":
            f = "geojson"
        if f not in FORMATS.values():
            raise MissionFileError(f"unknown mission format {fmt!r} (use plan, waypoints, geojson)")
        owner = FORMATS.get(suffix)
        if owner is not None and owner != f:
            raise MissionFileError(
                f"format {f} disagrees with the suffix {suffix} of {printable(path)} (a "
                f"{suffix} file is {FORMAT_TEXT[owner]}, {f} is {FORMAT_TEXT[f]}): name the "
                f"file .{f}, or leave the format out")  # fmt: skip
        return f
    if suffix not in FORMATS:
        known = ", ".join(FORMATS)
        raise MissionFileError(f"{printable(path)}: cannot tell the format from the suffix "
                               f"(use {known})")
    return FORMATS[suffix]


def home_of(map: Any) -> tuple[float, float, float]:  # noqa: A002
    """Planned home: the start point's latitude/longitude and the origin's altitude AMSL.

    Args:
        map: a loaded map with an origin.

    Returns:
        (lat, lon, alt): degrees, degrees, metres AMSL.

    Raises:
        MissingOriginError: the map has no origin.
    """
    lat, lon = enu_to_latlon(map.start[0], map.start[1], map)
    return float(lat), float(lon), float(map.spec.origin.alt)


def write_mission(
    path: str | Path,
    plan: Any,
    map: Any,  # noqa: A002
    fmt: str | None = None,
    *,
    finish: Literal["land", "rtl"] = "land",
    fence: bool = True,
    autopilot: str = "generic",
    planning_map: Any = None,
) -> Path:
    """Write `plan` on `map` as a mission file (atomically) and return the path.

    `.plan` holds the mission and (with `fence`) an exclusion geofence for every obstacle of
    `map` (the uninflated shapes: a clearance is the planner's business, not the fence's);
    `.waypoints` holds the mission only; `.geojson` holds the map and plan for display.
    Every number written is what `autopilot` (px4, ardupilot, generic) stores: the plan is
    first made storable (`lamde_mission.storage.storable_plan`, on `planning_map` when the plan
    was made on a map with safety margins; a storable plan it made for these maps is kept as
    it is), so lat/lon lie on the 1e-7 degree grid, parameters are float32 values and hover
    times are rounded *up* to whole seconds where the autopilot keeps whole seconds; storing
    the file changes nothing. Storage makes up no shortfall the plan has as planned (an
    infeasible plan is written infeasible, for `verify` to judge).

    Args:
        path: the file to write.
        plan: the plan (a `Plan` or anything with `hover_points` (I, 2) m and `hover_times`
            (I,) s).
        map: the map it was planned for, with an origin.
        fmt: "plan", "waypoints" or "geojson" (`format_for`); None: from the suffix.
        finish: end the mission with LAND or RETURN_TO_LAUNCH.
        fence: write the exclusion geofence (`.plan` only).
        autopilot: "px4", "ardupilot" or "generic": how the vehicle stores the numbers.
        planning_map: the map the plan was made on (with safety margins), when not `map`.

    Returns:
        The path written.

    Raises:
        MissionFileError: the format cannot be told (`format_for`).
        ValueError: an unknown `autopilot`, or numbers a file cannot hold (hover points not
            (I, 2), hover times not one per point, a non-finite number, a negative time).
    """
    from lamde_mission.storage import dialect_of, storable_plan, stored_items

    dialect = dialect_of(autopilot)
    kind = format_for(path, fmt)
    if kind == "geojson":
        from lamde_mission.formats.geojson import write_geojson

        return write_geojson(path, plan, map)
    plan = storable_plan(plan, map, dialect, planning_map=planning_map, finish=finish)
    items = stored_items(plan_to_items(plan, map, finish=finish), dialect)
    home = home_of(map)
    home = (float(grid_degrees(home[0])), float(grid_degrees(home[1])), float32(home[2]))
    if kind == "plan":
        from lamde_mission.formats.qgc_plan import write_qgc_plan

        # an exclusion circle's float32 radius is rounded up, never shrinking the fence
        fence_items = [replace(it, param1=float32_up(it.param1))
                       if it.command == CMD.FENCE_CIRCLE_EXCLUSION else it
                       for it in geofence_items(map)] if fence else []  # fmt: skip
        fence_items = stored_items(fence_items, dialect)
        v = float32(map.spec.uav.max_speed)
        return write_qgc_plan(path, items, fence_items, home=home, cruise_speed=v,
                              firmware_type=dialect.firmware_type)  # fmt: skip
    from lamde_mission.formats.waypoints import write_waypoints

    return write_waypoints(path, items, home)


def read_mission(path: str | Path) -> tuple[list[MissionItem], list[MissionItem]]:
    """(mission items, fence items) of a `.plan` or `.waypoints` file (`read_mission_lists`
    also gives the rally points; an upload must use it, to leave nothing out).

    Args:
        path: the file; recognised by its content, whatever its suffix.

    Returns:
        (mission, fence) items; the fence is empty for a `.waypoints` file.

    Raises:
        MissionFileError: naming the file, for anything unreadable or unsupported (a GeoJSON
            file is refused: it is a display format without MAVLink commands).
    """
    mission, fence, _rally = read_mission_lists(path)
    return mission, fence


def read_mission_lists(
    path: str | Path,
) -> tuple[list[MissionItem], list[MissionItem], list[MissionItem]]:
    """(mission, fence, rally) items of a `.plan` or `.waypoints` file (a `.waypoints` file
    has neither fence nor rally). A UTF-8 byte-order mark is accepted.

    Args:
        path: the file; recognised by its content ("QGC WPL" text or a JSON object),
            whatever its suffix.

    Returns:
        (mission, fence, rally) lists of `MissionItem`.

    Raises:
        MissionFileError: naming the file, for anything unreadable or unsupported (a GeoJSON
            FeatureCollection included).
    """
    path = Path(path)
    try:
        text = read_text(path)
    except InputError as exc:
        raise MissionFileError(f"{printable(path)}: {exc}") from None
    head = text.lstrip()
    try:
        if head.startswith("QGC WPL"):
            from lamde_mission.formats.waypoints import parse_waypoints

            return parse_waypoints(text)[1], [], []
        if head.startswith("{"):
            try:
                doc = loads_json(text)
            except InputError as exc:
                raise MissionError(str(exc)) from None
            if isinstance(doc, dict) and doc.get("type") == "FeatureCollection":
                raise MissionError(
                    "a GeoJSON file is a display export, not a mission; use the .plan or "
                    ".waypoints file written with it"
                )
            from lamde_mission.formats.qgc_plan import parse_plan_lists

            return parse_plan_lists(doc)
    except MissionError as exc:
        raise MissionFileError(f"{printable(path)}: {exc}") from None
    raise MissionFileError(
        f"{printable(path)}: not a mission file (expected a QGroundControl .plan or a "
        "'QGC WPL 110' .waypoints file)"
    )


def load_mission_items(
    path: str | Path,
    map: Any,  # noqa: A002
) -> tuple[list[MissionItem], list[MissionItem]]:
    """Like `read_mission`, and also accepts a saved plan result (JSON with hover_points and
    hover_times, as `Plan.to_dict` writes, or the report `plan --report` writes: its `stored`
    mission), turned into items on `map` with `plan_to_items`.

    Args:
        path: a `.plan` or `.waypoints` file, or a `.json` plan result or report.
        map: the map (with its origin) a plan result is placed on.

    Returns:
        (mission, fence) items; for a plan result, the fence is the map's geofence
        (`geofence_items`) and the mission is as its `autopilot` stores it, when the report
        names one.

    Raises:
        MissionFileError: naming the file, for anything unreadable or unsupported, or bad
            hover_points/hover_times.
    """
    path = Path(path)
    if path.suffix.lower() == ".json":
        try:
            doc = read_json(path)
        except InputError as exc:
            raise MissionFileError(f"{printable(path)}: {exc}") from None
        if isinstance(doc, dict) and isinstance(doc.get("stored"), dict):
            doc = doc["stored"]  # `plan --report`: the mission as written (storable plan)
        elif isinstance(doc, dict) and isinstance(doc.get("plan"), dict):
            doc = doc["plan"]  # an older report: the optimiser's plan
        if isinstance(doc, dict) and "hover_points" in doc and "hover_times" in doc:
            from types import SimpleNamespace

            from lamde_mission.formats.ranges import check_mission_item

            try:
                plan = SimpleNamespace(hover_points=doc["hover_points"],
                                       hover_times=doc["hover_times"])  # fmt: skip
                _check_plan_result(plan.hover_points, plan.hover_times)
                finish = "rtl" if doc.get("finish") == "rtl" else "land"
                items = plan_to_items(plan, map, finish=finish)
                for k, it in enumerate(items):
                    check_mission_item(it, lambda f, k=k: f"hover_points/hover_times: item {k} {f}")
                if doc.get("autopilot") in DIALECTS:  # the report's stored mission, as written
                    items = stored_items(items, doc["autopilot"])
                return items, geofence_items(map)
            except MissionError as exc:
                raise MissionFileError(f"{printable(path)}: {exc}") from None
            except (TypeError, ValueError) as exc:
                raise MissionFileError(f"{printable(path)}: bad hover_points/hover_times "
                                       f"({exc})") from None
    return read_mission(path)


def _check_plan_result(hover_points: Any, hover_times: Any) -> None:
    """Shapes and ranges of a plan result's hover points (local metres) and times (s), before
    any of them reaches numpy or the geodesy; MissionError naming the entry."""
    import math

    from lamde_mission.formats.ranges import FLOAT32_MAX, check_item_count
    from planner_core.defaults import interval_text
    from planner_core.model.mapio import MAX_COORD

    def number(v: Any, where: str, lo: float, hi: float) -> None:
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise MissionError(f"{where}: expected a number, got {quoted(v)}")
        if not (math.isfinite(v) and lo <= v <= hi):
            raise MissionError(f"{where}: {v:g} is outside {interval_text(lo, hi)}")

    for name, v in (("hover_points", hover_points), ("hover_times", hover_times)):
        if not isinstance(v, list):
            raise MissionError(f"{name}: expected a list")
        check_item_count(len(v), name)
    if len(hover_points) != len(hover_times):
        raise MissionError(f"hover_points and hover_times differ in length "
                           f"({len(hover_points)} and {len(hover_times)})")  # fmt: skip
    for k, p in enumerate(hover_points):
        if not isinstance(p, list) or len(p) != 2:
            raise MissionError(f"hover_points[{k}]: expected [x, y] in metres")
        for i, c in enumerate(p):
            number(c, f"hover_points[{k}][{i}]", -MAX_COORD, MAX_COORD)
    for k, t in enumerate(hover_times):
        number(t, f"hover_times[{k}]", 0.0, FLOAT32_MAX)

"""GIS layers (GeoJSON, QGroundControl geofence) -> a map file in the local frame.

Inputs
------
* GeoJSON (RFC 7946): a FeatureCollection, a Feature or a bare geometry; positions are
  [longitude, latitude] in WGS84 (a legacy ``crs`` member naming anything else is refused).
  A feature's layer is its ``kind`` property: ``sensor`` (Point or MultiPoint; optional ``id``
  (when missing or null: ``name``, else ``s<n>``) and ``required_data`` in Mbit), ``obstacle``
  or its alias ``building`` (Polygon or MultiPolygon; with ``shape: "rectangle"``, ``center``,
  ``length_m``, ``width_m`` and ``angle_deg``, as `map to-geojson` writes rectangles, the
  rectangle while the outline matches it within `RECTANGLE_TOLERANCE`), ``no_fly_zone`` (Polygon
  or MultiPolygon), ``start`` and ``end`` (Points), ``depot`` (a Point: a take-off, landing
  and battery-swap site of ``fleet.depots``, named by its ``name`` property, else ``d<n>``),
  ``area`` (a Polygon; see below),
  ``circle`` (``center`` [lon, lat] and ``radius_m`` properties, as `map to-geojson` writes
  circular obstacles). A file given with ``--obstacles``, ``--no-fly-zones`` or ``--sensors``
  is that layer whole (footprint exports carry no ``kind``).
* QGroundControl ``.plan`` (detected by ``"fileType": "Plan"``): its geofence's exclusion
  polygons become no-fly zones, its exclusion circles circular obstacles, its inclusion polygons
  (and circles) the area; the planned home position is the start and the end unless the other
  inputs give them, and its altitude (m AMSL) the origin's unless one is given.
* Map settings: an ``area`` feature written by `map to-geojson` carries the map's non-geometric
  sections (``name``, ``uav``, ``radio``, ``objective``, ``safety``, ``fleet``, ``witness``) in
  its properties; they are restored as given (the map loader validates them). Without them
  the map defaults apply. ``depot`` features, where any are given, are the fleet's depots, in
  their order: they take precedence over depots in the carried ``fleet`` section (as older
  exports wrote them; a note says they were replaced), so a depot moved, added or deleted in a
  GIS is what the map gets.

The local frame
---------------
Origin: ``origin`` if given; else the south-west corner of the data's bounding box (sensors,
obstacles, zones, start, end) grown by ``margin`` metres (default 100 m) on every side, so every
feature lies inside the area [0, W] x [0, H] with at least that margin. W and H reach the data's
north-east corner plus the margin. Positions go through the project's ENU <-> WGS84 conversion
(`lamde_mission.geo`). An ``area`` Polygon feature, or QGroundControl inclusion fences, fix the
area instead: its bounding box is the map's area, and the part of the box outside it becomes a
no-fly zone, so "stay inside" holds exactly. An ``area`` feature that carries ``origin``,
``width_m`` and ``height_m`` (as `to_geojson` writes them) is taken literally, so a map exported and
imported again keeps its frame. Several inclusion regions (QGroundControl inclusion polygons and
circles, GeoJSON ``area`` features) give their intersection (`INCLUSION_RULE` says why); none in
common is refused naming them.

Features outside the area: obstacles and zones are clipped to it (a leg between points inside
the rectangular area never leaves it, so L_vio is unchanged; noted when one reached more than
`CLIP_TOLERANCE` beyond the area), those wholly outside are dropped;
sensors, start and end outside are refused. Rings are cleaned as the map loader does (closing,
near-duplicate and collinear vertices within 5 mm; orientation), and a self-intersecting ring is
refused naming the feature. Every problem is one line naming the file and feature.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from planner_core.textio import (
    InputError,
    counted,
    for_count,
    loads_json,
    printable,
    quoted,
    read_json,
)
from sim.geo import enu_to_latlon, latlon_to_enu

__all__ = ["GisError", "GisLayers", "read_layers", "build_map", "DEFAULT_MARGIN", "KINDS"]

#: metres added around the data's bounding box when the area is not given
DEFAULT_MARGIN = 100.0
#: metres: parts of the area outside an inclusion fence thinner than this are not no-fly zones
#: (the fence's straight edges in WGS84 are a few millimetres off the local frame's axes)
SLIVER_WIDTH = 0.1
#: segments per quarter circle of an inclusion circle's inscribed polygon (QGroundControl)
INCLUSION_CIRCLE_QUAD_SEGS = 16
#: metres: an obstacle or zone reaching no farther than this outside the area lies on its edge
#: (a WGS84 round trip moves vertices by far less): it is clipped without a note
CLIP_TOLERANCE = 0.01
#: metres: a rectangle's drawn outline may differ this much from its `center`, `length_m`,
#: `width_m` and `angle_deg` properties and still be read back as that rectangle
RECTANGLE_TOLERANCE = 0.01
#: why several inclusion fences are intersected (docs/maps.md, "Several inclusion fences")
INCLUSION_RULE = (
    "ArduPilot breaches a vehicle outside any one inclusion fence (AC_PolyFence_loader.cpp "
    "breached(), unless its FENCE_OPTIONS union bit is set), as does PX4 since PR #22394 "
    "(geofence.cpp, Nov 2023), while earlier PX4 breached only outside all of them: a mission "
    "inside the intersection flies on both"
)

KINDS = {
    "sensor": "sensor",
    "obstacle": "obstacle",
    "building": "obstacle",
    "no_fly_zone": "no_fly_zone",
    "no-fly-zone": "no_fly_zone",
    "start": "start",
    "end": "end",
    "area": "area",
    "circle": "circle",
    "depot": "depot",
}
LAYER_OPTIONS = {"obstacle": "--obstacles", "no_fly_zone": "--no-fly-zones", "sensor": "--sensors"}


class GisError(ValueError):
    """Input that cannot become a map; `problems` holds one line each, naming file and feature."""

    def __init__(self, problems: list[str]):
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))


class _OverLimit(Exception):
    """A count limit (`planner_core.textio.LIMITS`) passed while reading: reading stops at
    once (not a ValueError, so the per-feature loop does not go on past it)."""


class _Budget:
    """Counts of what the inputs hold so far, against the map loader's limits (sensors,
    obstacles, vertices of one ring, vertices of all rings), checked as each feature is read
    and before its positions are converted: a ring of 1,000,000 vertices or a MultiPoint of
    1.5 M sensors is refused at once, not after the whole import."""

    def __init__(self) -> None:
        from planner_core import textio

        try:
            self.caps = {k: textio.limit(k)
                         for k in ("sensors", "obstacles", "zone_vertices", "vertices")}
        except textio.InputError as exc:
            raise _OverLimit(f"(environment) {exc}") from None
        self.used = dict.fromkeys(self.caps, 0)

    def take(self, key: str, n: int, where: str) -> None:
        """Count `n` more of `key` at `where`; _OverLimit naming it once past the limit."""
        from planner_core import textio

        self.used[key] += n
        what = {"sensors": "sensors", "obstacles": "obstacles", "vertices": "vertices of all "
                "rings", "zone_vertices": "vertices in one ring"}[key]  # fmt: skip
        if key == "zone_vertices":
            self.used[key] = 0  # per ring: only this ring's count matters
            if n <= self.caps[key]:
                return
            lim = textio.LIMITS[key]
            raise _OverLimit(f"{where}: {n:,} {what}, more than the limit of "
                             f"{self.caps[key]:,} (raise it with {lim.env})")  # fmt: skip
        if self.used[key] > self.caps[key]:
            lim = textio.LIMITS[key]
            raise _OverLimit(f"{where}: more than the limit of {self.caps[key]:,} {what} in "
                             f"the inputs so far (raise it with {lim.env}); reading "
                             "stopped here")  # fmt: skip


@dataclass
class _Poly:
    where: str
    name: str | None
    rings: list[list[tuple[float, float]]]  # lon, lat; exterior first
    group: str = ""  # the feature or fence it belongs to (a MultiPolygon's parts share one)
    fence: bool = False  # a QGroundControl inclusion fence (else a GeoJSON `area` polygon)


@dataclass
class GisLayers:
    """What the inputs hold, still in WGS84 (lon, lat)."""

    sensors: list[dict[str, Any]] = field(default_factory=list)  # where, id, lon, lat, q
    obstacles: list[_Poly] = field(default_factory=list)
    no_fly_zones: list[_Poly] = field(default_factory=list)
    circles: list[dict[str, Any]] = field(default_factory=list)  # where, lon, lat, radius
    areas: list[_Poly] = field(default_factory=list)  # polygons the flight must stay within
    area_circles: list[dict[str, Any]] = field(default_factory=list)
    area_frame: dict[str, Any] | None = None  # origin, width_m, height_m of an exported area
    # where, lon, lat, length, width, angle, poly: rectangles as `map to-geojson` writes them
    rectangles: list[dict[str, Any]] = field(default_factory=list)
    settings: dict[str, Any] | None = None  # name, uav, radio, ... carried by an exported area
    settings_where: str | None = None  # the feature that carried them
    settings_text: list[str] = field(default_factory=list)  # sections given as JSON text
    start: dict[str, Any] | None = None  # where, lon, lat
    end: dict[str, Any] | None = None
    home: dict[str, Any] | None = None  # QGC planned home position (where, lon, lat, alt)
    depots: list[dict[str, Any]] = field(default_factory=list)  # where, name, lon, lat
    problems: list[str] = field(default_factory=list)
    budget: _Budget | None = field(default=None, repr=False)  # counts against the limits

    def take(self, key: str, n: int, where: str) -> None:
        """Count `n` more of `key` (`_Budget.take`); nothing when no budget is kept.

        Args:
            key: "sensors", "obstacles", "vertices" (of all rings) or "zone_vertices" (of
                one ring).
            n: how many more.
            where: the file and feature, for the message.

        Raises:
            _OverLimit: the count passes its limit (`planner_core.textio.LIMITS`): reading
                stops at once.
        """
        if self.budget is not None:
            self.budget.take(key, n, where)


# ----------------------------------------------------------------------------- reading


def _positive(r: Any) -> bool:
    return (not isinstance(r, bool)) and isinstance(r, int | float) and r > 0 and math.isfinite(r)


def _size(v: Any, where: str) -> float:
    """A size in metres (a radius, a rectangle's side): a number > 0 and at most the map's
    `MAX_COORD`; ValueError naming `where` otherwise (1e308 overflowed the frame's arithmetic
    into warnings and a wrong message, or a traceback)."""
    from planner_core.model.mapio import MAX_COORD

    if not _positive(v):
        raise ValueError(f"{where}: must be a number > 0 (metres), got {quoted(v)}")
    if v > MAX_COORD:
        raise ValueError(f"{where}: {v:g} m is more than {MAX_COORD:g} m, the largest size a "
                         "map's obstacle may have")  # fmt: skip
    return float(v)


def _position(p: Any, where: str) -> tuple[float, float]:
    if not isinstance(p, list | tuple) or len(p) < 2:
        raise ValueError(f"{where}: a position must be [longitude, latitude]")
    if len(p) > 3 or (len(p) == 3 and (isinstance(p[2], bool)
                                       or not isinstance(p[2], int | float))):  # fmt: skip
        raise ValueError(f"{where}: a position is [longitude, latitude] or [longitude, "
                         f"latitude, altitude], numbers (RFC 7946); got {quoted(list(p))}")
    lon, lat = p[0], p[1]
    if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in (lon, lat)):
        raise ValueError(f"{where}: coordinates must be numbers")
    lon, lat = float(lon), float(lat)
    if not (math.isfinite(lon) and math.isfinite(lat)):
        raise ValueError(f"{where}: coordinates must be finite")
    if not (-180.0 <= lon <= 180.0 and -90.0 <= lat <= 90.0):
        raise ValueError(
            f"{where}: ({lon:g}, {lat:g}) is not a WGS84 [longitude, latitude] (RFC 7946); "
            "reproject projected data to EPSG:4326 first"
        )
    return lon, lat


def _rings(coords: Any, where: str, layers: GisLayers) -> list[list[tuple[float, float]]]:
    if not isinstance(coords, list) or not coords:
        raise ValueError(f"{where}: a Polygon needs at least its exterior ring")
    out = []
    for r, ring in enumerate(coords):
        if not isinstance(ring, list):
            raise ValueError(f"{where}: ring {r} is not a list of positions")
        layers.take("zone_vertices", len(ring), f"{where} ring {r}")
        layers.take("vertices", len(ring), f"{where} ring {r}")
        out.append([_position(p, f"{where} ring {r}") for p in ring])
    return out


#: the property keys a feature's label is read from, in order (shapefile and many GIS exports
#: write upper-case field names: a building's ``NAME``)
_NAME_KEYS = ("name", "NAME", "Name")


def _label(where: str, props: dict[str, Any]) -> tuple[str, str | None]:
    """(the feature's label for messages, its name): the name escaped (`printable`) and cut
    to 80 characters in the label, so a name cannot forge output lines or copy megabytes."""
    key = next((k for k in _NAME_KEYS if props.get(k) is not None), None)
    name = None if key is None else props[key]
    if name is not None and (isinstance(name, bool) or not isinstance(name, str | int | float)):
        raise ValueError(f"{where}: properties.{key}: a name is text (or a number), got "
                         f"{quoted(name)}")  # fmt: skip
    name = str(name) if name is not None else None
    if not name:
        return where, name
    shown = printable(name[:80]) + ("..." if len(name) > 80 else "")
    return f"{where} '{shown}'", name


def _add_feature(layers: GisLayers, feat: Any, where: str, layer: str | None) -> None:
    if not isinstance(feat, dict) or feat.get("type") != "Feature":
        raise ValueError(f"{where}: not a GeoJSON Feature")
    props = feat.get("properties") or {}
    if not isinstance(props, dict):
        raise ValueError(f"{where}: properties must be an object")
    label, name = _label(where, props)
    kind = layer
    if kind is None:
        raw = props.get("kind")
        if raw is None:
            raise ValueError(
                f"{label}: no 'kind' property (sensor, obstacle/building, no_fly_zone, start, "
                "end, depot, area); or give the whole file as one layer with --obstacles, "
                "--no-fly-zones or --sensors"
            )
        kind = KINDS.get(str(raw).strip().lower())
        if kind is None:
            raise ValueError(f"{label}: unknown kind {quoted(raw)} (expected one of: "
                             f"{', '.join(sorted(KINDS))})")  # fmt: skip
    if kind == "circle":  # as `map to-geojson` writes circles: centre and radius in properties
        r = props.get("radius_m")
        if not _positive(r):
            raise ValueError(f"{label}: a circle needs radius_m > 0 and center [lon, lat]")
        r = _size(r, f"{label} radius_m")
        layers.take("obstacles", 1, label)
        lon, lat = _position(props.get("center"), f"{label} center")
        layers.circles.append({"where": label, "lon": lon, "lat": lat, "radius": r})
        return
    geom = feat.get("geometry")
    if not isinstance(geom, dict):
        raise ValueError(f"{label}: has no geometry")
    gtype, coords = geom.get("type"), geom.get("coordinates")
    if kind in ("sensor", "start", "end", "depot"):
        if gtype == "Point":
            points = [_position(coords, label)]
        elif gtype == "MultiPoint" and kind == "sensor":
            if not isinstance(coords, list):
                raise ValueError(f"{label}: MultiPoint coordinates must be a list")
            layers.take("sensors", len(coords), label)
            points = [_position(p, label) for p in coords]
        else:
            raise ValueError(f"{label}: {kind} features must be a Point, got {gtype}")
        if kind == "sensor":
            if gtype == "Point":
                layers.take("sensors", 1, label)
            q = props.get("required_data")
            if q is not None and (isinstance(q, bool) or not isinstance(q, int | float)
                                  or not math.isfinite(q) or q < 0):  # fmt: skip
                raise ValueError(f"{label}: required_data must be a number >= 0 (Mbit)")
            base = props.get("id")  # an "id": null (a GIS writes empty fields so) is no id
            if base is not None and (isinstance(base, bool) or not isinstance(base, str | int)):
                raise ValueError(f"{label}: properties.id: a sensor id is text (or an "
                                 f"integer), got {quoted(base)}")  # fmt: skip
            if base is None:
                base = name
            for k, (lon, lat) in enumerate(points):
                sid = None if base is None else (str(base) if len(points) == 1 else f"{base}-{k}")
                layers.sensors.append({"where": label, "id": sid, "lon": lon, "lat": lat,
                                       "required_data": q})  # fmt: skip
        elif kind == "depot":
            layers.depots.append({"where": label, "name": name, "lon": points[0][0],
                                  "lat": points[0][1]})  # fmt: skip
        else:
            if getattr(layers, kind) is not None:
                first = getattr(layers, kind)["where"]
                raise ValueError(f"{label}: a second '{kind}' (the first: {first})")
            setattr(layers, kind, {"where": label, "lon": points[0][0], "lat": points[0][1]})
        return
    # polygon layers
    if kind != "area" and gtype in ("Polygon", "MultiPolygon"):
        layers.take("obstacles", len(coords) if gtype == "MultiPolygon" and
                    isinstance(coords, list) else 1, label)  # fmt: skip
    if gtype == "Polygon":
        polys = [_rings(coords, label, layers)]
    elif gtype == "MultiPolygon":
        if not isinstance(coords, list):
            raise ValueError(f"{label}: MultiPolygon coordinates must be a list")
        if not coords:  # the obstacle or zone would vanish without a word
            raise ValueError(f"{label}: a MultiPolygon with no polygons (give at least one, "
                             "or leave the feature out)")  # fmt: skip
        polys = [_rings(c, f"{label} polygon {k}", layers) for k, c in enumerate(coords)]
    else:
        raise ValueError(f"{label}: {kind} features must be a Polygon or MultiPolygon, "
                         f"got {gtype}")  # fmt: skip
    if kind == "obstacle" and gtype == "Polygon" and props.get("shape") == "rectangle":
        rect = _rectangle_props(props, label)
        if rect is not None:  # else the outline drawn is the obstacle, a polygon
            layers.rectangles.append({"where": label, **rect,
                                      "poly": _Poly(label, name, polys[0], label)})
            return
    target = {"obstacle": layers.obstacles, "no_fly_zone": layers.no_fly_zones,
              "area": layers.areas}[kind]  # fmt: skip
    for k, rings in enumerate(polys):
        at = label if len(polys) == 1 else f"{label} polygon {k}"
        target.append(_Poly(at, name, rings, label))
    if kind == "area":
        framed = all(key in props for key in ("origin", "width_m", "height_m"))
        if framed:
            layers.area_frame = {"where": label, "origin": props["origin"],
                                 "width": props["width_m"], "height": props["height_m"]}
        _read_settings(layers, props, label, framed)


def _rectangle_props(props: dict[str, Any], label: str) -> dict[str, float] | None:
    """A rectangle's centre (lon, lat), sides and angle from the properties `map to-geojson`
    writes; None where one is missing or not a number in range; ValueError naming the feature
    for a side larger than any map's obstacle."""
    try:
        lon, lat = _position(props.get("center"), "center")
    except ValueError:
        return None
    length, width, angle = props.get("length_m"), props.get("width_m"), props.get("angle_deg")
    if not (_positive(length) and _positive(width)):
        return None
    length, width = _size(length, f"{label} length_m"), _size(width, f"{label} width_m")
    if isinstance(angle, bool) or not isinstance(angle, int | float) or not math.isfinite(angle):
        return None
    return {"lon": lon, "lat": lat, "length": float(length), "width": float(width),
            "angle": float(angle)}  # fmt: skip


def _settings_keys() -> tuple[str, ...]:
    """The map file's top-level sections that are settings, not geometry (name, uav, radio,
    objective, safety, fleet, witness, and any the schema gains)."""
    from lamde_mission.gis.export import SETTINGS_EXCLUDED
    from planner_core.model.mapio import MapFile

    return tuple(k for k in MapFile.model_fields if k not in SETTINGS_EXCLUDED)


def _read_settings(layers: GisLayers, props: dict[str, Any], label: str, framed: bool) -> None:
    """Keep the map settings an `area` feature carries (as `map to-geojson` writes them). A
    plain area polygon's `name` is a label, not the map's name: the name counts only beside
    the exported frame or another section."""
    carried = {k: props[k] for k in _settings_keys() if k in props and props[k] is not None}
    if not carried or (set(carried) == {"name"} and not framed):
        return
    for k, v in carried.items():
        # a GIS editor (QGIS) saves a nested property as its JSON text: read it back
        if k != "name" and isinstance(v, str) and v.lstrip().startswith(("{", "[")):
            try:
                carried[k] = loads_json(v)
            except InputError as e:
                raise ValueError(f"{label}: properties.{k}: a JSON text that does not parse "
                                 f"({e})") from None
            layers.settings_text.append(k)
    if layers.settings is not None:
        raise ValueError(f"{label}: a second area carrying map settings (the first: "
                         f"{layers.settings_where})")  # fmt: skip
    layers.settings, layers.settings_where = carried, label


def _read_geojson(layers: GisLayers, doc: Any, src: str, layer: str | None) -> None:
    if not isinstance(doc, dict):
        raise ValueError(f"{src}: not a GeoJSON object")
    crs = doc.get("crs")
    if crs is not None:
        props = crs.get("properties") if isinstance(crs, dict) else None
        name = props.get("name") if isinstance(props, dict) else None
        name = name if isinstance(name, str) else ""
        if not any(t in name for t in ("CRS84", "4326")):
            raise ValueError(f"{src}: crs {quoted(name or crs)} is not WGS84; RFC 7946 GeoJSON is "
                             "WGS84 longitude/latitude (reproject to EPSG:4326 first)")  # fmt: skip
    t = doc.get("type")
    if t == "FeatureCollection":
        feats = doc.get("features")
        if not isinstance(feats, list):
            raise ValueError(f"{src}: features must be a list")
        for k, f in enumerate(feats):
            try:
                _add_feature(layers, f, f"{src}: features[{k}]", layer)
            except ValueError as exc:
                layers.problems.append(str(exc))
    elif t == "Feature":
        _add_feature(layers, doc, f"{src}: feature", layer)
    elif t in ("Point", "MultiPoint", "Polygon", "MultiPolygon"):
        if layer is None:
            raise ValueError(f"{src}: a bare {t} has no 'kind'; give the file with "
                             "--obstacles, --no-fly-zones or --sensors")  # fmt: skip
        _add_feature(layers, {"type": "Feature", "geometry": doc, "properties": {}},
                     f"{src}: geometry", layer)  # fmt: skip
    else:
        raise ValueError(f"{src}: not GeoJSON (type {quoted(t)}; expected FeatureCollection, "
                         "Feature or a geometry)")  # fmt: skip


def _number(v: Any, where: str) -> float:
    """A JSON number (not a string, not a boolean), finite; ValueError naming `where`."""
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        shown = repr(v) if len(repr(v)) <= 40 else repr(v)[:37] + "..."
        raise ValueError(f"{where}: must be a finite JSON number, got {shown}")
    return float(v)


def _read_qgc_plan(layers: GisLayers, doc: dict[str, Any], src: str) -> None:
    from lamde_mission.formats.qgc_plan import _bool, _check_sections, _check_versions
    from lamde_mission.items import MissionError

    try:  # the sections and versions `verify` and `upload` accept, strict booleans, as they do
        _check_sections(doc)
        _check_versions(doc)
        for key in ("polygons", "circles"):
            for k, shape in enumerate((doc.get("geoFence") or {}).get(key) or []):
                if isinstance(shape, dict):
                    _bool(shape, "inclusion", f"geoFence.{key}[{k}]", True)
    except MissionError as exc:
        raise ValueError(f"{src}: {exc}") from None
    gf = doc.get("geoFence") or {}
    if not isinstance(gf, dict):
        raise ValueError(f"{src}: geoFence is not an object")
    for k, poly in enumerate(gf.get("polygons") or []):
        where = f"{src}: geoFence.polygons[{k}]"
        verts = poly.get("polygon") if isinstance(poly, dict) else None
        if not isinstance(verts, list) or len(verts) < 3:
            raise ValueError(f"{where}: needs at least 3 [lat, lon] vertices")
        if poly.get("inclusion", True) is False:
            layers.take("obstacles", 1, where)
        layers.take("zone_vertices", len(verts), f"{where}.polygon")
        layers.take("vertices", len(verts), f"{where}.polygon")
        ring = []
        for i, v in enumerate(verts):
            if not isinstance(v, list) or len(v) < 2:
                raise ValueError(f"{where}.polygon[{i}]: expected [lat, lon]")
            ring.append(_position([v[1], v[0]], f"{where}.polygon[{i}]"))
        inclusion = bool(poly.get("inclusion", True))  # QGC: a missing key means inclusion
        (layers.areas if inclusion else layers.no_fly_zones).append(
            _Poly(where, None, [ring], where, fence=True))
    for k, c in enumerate(gf.get("circles") or []):
        where = f"{src}: geoFence.circles[{k}]"
        circle = c.get("circle") if isinstance(c, dict) else None
        centre = circle.get("center") if isinstance(circle, dict) else None
        if not isinstance(centre, list) or len(centre) < 2:
            raise ValueError(f"{where}: missing circle.center [lat, lon]")
        lon, lat = _position([centre[1], centre[0]], f"{where}.circle.center")
        r = circle.get("radius")
        if not _positive(r):
            raise ValueError(f"{where}.circle.radius: must be a positive number (metres)")
        entry = {"where": where, "lon": lon, "lat": lat,
                 "radius": _size(r, f"{where}.circle.radius")}
        if c.get("inclusion", True) is False:
            layers.take("obstacles", 1, where)
        (layers.area_circles if c.get("inclusion", True) else layers.circles).append(entry)
    home = (doc.get("mission") or {}).get("plannedHomePosition")
    if isinstance(home, list) and len(home) >= 2:
        lon, lat = _position([home[1], home[0]], f"{src}: mission.plannedHomePosition")
        alt = None  # [lat, lon, altitude AMSL], as QGroundControl writes it
        if len(home) >= 3 and home[2] is not None:
            alt = _home_altitude(home[2], f"{src}: mission.plannedHomePosition[2]")
        if layers.home is not None and (layers.home["lon"], layers.home["lat"],
                                        layers.home["alt"]) != (lon, lat, alt):
            # two .plan inputs: the start, the end and the origin's altitude would follow
            # whichever was read last
            raise ValueError(f"{src}: mission.plannedHomePosition: a second planned home, "
                             f"not the one of {layers.home['where']}")
        layers.home = {"where": f"{src}: planned home", "lon": lon, "lat": lat, "alt": alt}


def _home_altitude(v: Any, where: str) -> float:
    """The planned home's altitude (m AMSL), within the map origin's range; ValueError naming
    `where` otherwise."""
    from planner_core.defaults import interval_text
    from planner_core.model.mapio import Origin

    alt = _number(v, where)
    bounds = Origin.model_json_schema()["properties"]["alt"]
    lo, hi = bounds.get("minimum", -math.inf), bounds.get("maximum", math.inf)
    if not lo <= alt <= hi:
        raise ValueError(f"{where}: altitude {alt:g} m is outside {interval_text(lo, hi)} m, "
                         "the range of a map origin's altitude above mean sea level")  # fmt: skip
    return alt


def read_layers(files: list[tuple[str | Path, str | None]]) -> GisLayers:
    """Read the input files' features, still in WGS84.

    Args:
        files: (path, layer) pairs; layer None: each feature's ``kind`` says its layer (or the
            file is a QGroundControl plan); else "obstacle", "no_fly_zone" or "sensor" for the
            whole file.

    Returns:
        The layers read, with the map settings an exported ``area`` feature carries.

    Raises:
        GisError: every problem found, one line each, naming file and feature.
    """
    try:
        layers = GisLayers(budget=_Budget())
    except _OverLimit as exc:
        raise GisError([str(exc)]) from None
    for path, layer in files:
        src = printable(path)
        try:  # the one decoding path: regular file, size, UTF-8 (BOM ok), depth, numbers
            doc = read_json(path)
        except InputError as exc:
            layers.problems.append(f"{src}: {exc}")
            continue
        try:
            if isinstance(doc, dict) and doc.get("fileType") == "Plan":
                if layer is not None:
                    opt = LAYER_OPTIONS[layer]
                    raise ValueError(f"{src}: a QGroundControl plan cannot be given as {opt}; "
                                     "give it as a plain input")  # fmt: skip
                _read_qgc_plan(layers, doc, src)
            else:
                _read_geojson(layers, doc, src, layer)
        except ValueError as exc:
            layers.problems.append(str(exc))
        except _OverLimit as exc:  # stop reading: what was found so far, then the limit
            raise GisError([*layers.problems, str(exc)]) from None
    if layers.problems:
        raise GisError(layers.problems)
    return layers


# ----------------------------------------------------------------------------- building


def _parse_origin(value: Any, where: str) -> tuple[float, float, float]:
    if not isinstance(value, list | tuple) or len(value) not in (2, 3):
        raise GisError([f"{where}: origin must be [lat, lon] or [lat, lon, alt]"])
    try:
        lat, lon, *rest = (_number(v, f"{where}: origin[{k}]") for k, v in enumerate(value))
    except ValueError as exc:
        raise GisError([str(exc)]) from None
    alt = rest[0] if rest else 0.0
    if not (-90 <= lat <= 90 and -180 <= lon <= 180 and all(map(math.isfinite, (lat, lon, alt)))):
        raise GisError([f"{where}: origin ({lat:g}, {lon:g}) is not a latitude, longitude"])
    return lat, lon, alt


def _all_lonlat(layers: GisLayers) -> np.ndarray:
    pts: list[tuple[float, float]] = []
    for s in layers.sensors:
        pts.append((s["lon"], s["lat"]))
    rect_polys = [r["poly"] for r in layers.rectangles]
    for p in layers.obstacles + rect_polys + layers.no_fly_zones + layers.areas:
        for ring in p.rings[:1]:
            pts.extend(ring)
    for c in layers.circles + layers.area_circles:
        pts.append((c["lon"], c["lat"]))
    for e in (layers.start, layers.end, layers.home, *layers.depots):
        if e is not None:
            pts.append((e["lon"], e["lat"]))
    return np.array(pts, dtype=float).reshape(-1, 2)


def _labelled_lonlat(layers: GisLayers) -> list[tuple[str, np.ndarray]]:
    """The positions `_all_lonlat` takes, per feature: (its label in messages, (n, 2) lon, lat);
    a sensor's label names its id where the feature has no name."""
    out: list[tuple[str, np.ndarray]] = []
    for s in layers.sensors:
        label = s["where"]
        if s["id"] is not None and not label.endswith("'"):
            label = f"{label} '{printable(str(s['id'])[:80])}'"
        out.append((label, np.array([(s["lon"], s["lat"])], dtype=float)))
    rect_polys = [r["poly"] for r in layers.rectangles]
    for p in layers.obstacles + rect_polys + layers.no_fly_zones + layers.areas:
        if p.rings:
            out.append((p.where, np.asarray(p.rings[0], dtype=float).reshape(-1, 2)))
    for c in layers.circles + layers.area_circles:
        out.append((c["where"], np.array([(c["lon"], c["lat"])], dtype=float)))
    for e in (layers.start, layers.end, layers.home, *layers.depots):
        if e is not None:
            out.append((e["where"], np.array([(e["lon"], e["lat"])], dtype=float)))
    return out


def _box_fits(lo: np.ndarray, hi: np.ndarray, side: float) -> bool:
    """Whether the lon, lat box [lo, hi] (degrees) spans at most `side` metres each way (its
    corners in the local frame of its south-west corner, as `_frame` measures the data)."""
    if not (-90.0 <= lo[1] and hi[1] <= 90.0):
        return False
    corners = np.array([(lo[0], lo[1]), (hi[0], lo[1]), (lo[0], hi[1]), (hi[0], hi[1]),
                        (lo[0], 0.5 * (lo[1] + hi[1])), (hi[0], 0.5 * (lo[1] + hi[1]))])
    xy = _local(corners, (float(lo[1]), float(lo[0]), 0.0))
    w, h = np.ptp(xy, axis=0)
    return bool(w <= side and h <= side)


def _stray(layers: GisLayers, side: float) -> str | None:
    """The feature that alone keeps the others from fitting one map of at most `side` m a side,
    as a clause for the message ("features[3] 'b' at (lon 52.014000, lat 5.129000) lies far
    from the others; GeoJSON positions are [longitude, latitude]: is this one written
    [latitude, longitude]?", the question where swapping its coordinates puts it among the
    others); None when no one feature does. When several do (two features far apart), the one
    a swap brings among the others, else the one farthest from the others' centre.

    Cost: O(positions) (the box of all features but one from prefix and suffix boxes)."""
    feats = _labelled_lonlat(layers)
    if len(feats) < 2:
        return None
    lo = np.array([f.min(axis=0) for _, f in feats])
    hi = np.array([f.max(axis=0) for _, f in feats])
    n = len(feats)
    pre_lo, pre_hi = np.minimum.accumulate(lo), np.maximum.accumulate(hi)
    suf_lo = np.minimum.accumulate(lo[::-1])[::-1]
    suf_hi = np.maximum.accumulate(hi[::-1])[::-1]
    found = []  # (swap fits, distance from the others' centre, k)
    for k in range(n):
        parts_lo = [b for b in (pre_lo[k - 1] if k else None,
                                suf_lo[k + 1] if k + 1 < n else None) if b is not None]
        parts_hi = [b for b in (pre_hi[k - 1] if k else None,
                                suf_hi[k + 1] if k + 1 < n else None) if b is not None]
        r_lo, r_hi = np.min(parts_lo, axis=0), np.max(parts_hi, axis=0)
        if not _box_fits(r_lo, r_hi, side):
            continue
        swapped = feats[k][1][:, ::-1]
        swap = bool(np.all(np.abs(swapped[:, 1]) <= 90.0) and _box_fits(
            np.minimum(r_lo, swapped.min(axis=0)), np.maximum(r_hi, swapped.max(axis=0)), side))
        far = float(np.hypot(*(feats[k][1].mean(axis=0) - 0.5 * (r_lo + r_hi))))
        found.append((swap, far, k))
    if not found:
        return None
    swap, _, k = max(found)
    label, pts = feats[k]
    lon, lat = pts.mean(axis=0)
    at = "at" if len(pts) == 1 else "around"
    clause = f"{label} {at} (lon {lon:.6f}, lat {lat:.6f}) lies far from the others"
    if swap:
        clause += ("; GeoJSON positions are [longitude, latitude]: is this one written "
                   "[latitude, longitude]?")
    return clause


def _lonlat(e: dict[str, Any]) -> str:
    """A point feature's own position as the file gives it: 'lon X, lat Y' (6 decimals)."""
    return f"lon {float(e['lon']):.6f}, lat {float(e['lat']):.6f}"


def _local(lonlat: Any, origin: tuple[float, float, float]) -> np.ndarray:
    a = np.asarray(lonlat, dtype=float).reshape(-1, 2)
    x, y = latlon_to_enu(a[:, 1], a[:, 0], origin)
    return np.column_stack([x, y])


def _circle_bounds(c: dict[str, Any], origin: tuple[float, float, float]) -> np.ndarray:
    (x, y), = _local([(c["lon"], c["lat"])], origin)
    r = c["radius"]
    return np.array([[x - r, y - r], [x + r, y + r]])


def _inclusion_regions(layers: GisLayers, origin: tuple[float, float, float]) -> list[Any]:
    """(name, shapely geometry or None where a polygon is not simple, QGC fence?) per inclusion
    region in the local frame of `origin`: each QGroundControl inclusion polygon and circle, and
    each GeoJSON `area` feature (its MultiPolygon parts joined)."""
    import shapely
    from shapely.geometry import Polygon

    groups: dict[str, list[Any]] = {}
    fence: dict[str, bool] = {}
    for p in layers.areas:
        g = Polygon(_local(p.rings[0], origin))
        groups.setdefault(p.group or p.where, []).append(g if g.is_valid else None)
        fence[p.group or p.where] = p.fence
    regions: list[Any] = []
    for name, parts in groups.items():
        valid = all(g is not None for g in parts)
        regions.append((name, shapely.union_all(parts) if valid else None, fence[name]))
    for c in layers.area_circles:
        (x, y), = _local([(c["lon"], c["lat"])], origin)
        # inscribed polygon: the allowed region shrinks by at most r(1 - cos(pi/4/segs))
        regions.append((c["where"], shapely.Point(x, y).buffer(
            c["radius"], quad_segs=INCLUSION_CIRCLE_QUAD_SEGS), True))
    return regions


def _allowed(regions: list[Any]) -> Any:
    """Where the flight may go: the intersection of every inclusion region (INCLUSION_RULE);
    GisError naming them when they have no area in common."""
    import shapely

    allowed = shapely.intersection_all([g for _, g, _ in regions])
    if allowed.is_empty or allowed.area <= 0.0:
        names = ", ".join(name for name, _, _ in regions)
        raise GisError([f"the inclusion fences {names} do not overlap: a mission that flies on "
                        "ArduPilot and PX4 alike stays inside every one of them, and no place "
                        "is inside all of them"])
    return allowed


def _frame(layers: GisLayers, origin: tuple[float, float, float | None] | None,
           margin: float) -> tuple[tuple[float, float, float], float, float, bool, list[str]]:
    """(origin, width, height, area given, notes). An origin whose altitude is None takes the
    QGroundControl planned home's altitude, else the exported area's, else 0."""
    notes: list[str] = []
    home_alt = layers.home.get("alt") if layers.home is not None else None
    if origin is not None and origin[2] is None:
        alt, src = 0.0, None
        if home_alt is not None:
            alt, src = home_alt, layers.home["where"]
        elif layers.area_frame is not None:
            f = layers.area_frame
            alt, src = _parse_origin(f["origin"], f["where"])[2], f["where"]
        origin = (origin[0], origin[1], alt)
        if src is not None:
            notes.append(f"origin altitude {alt:g} m from {src}")
    if layers.area_frame is not None and origin is None:
        f = layers.area_frame
        o = _parse_origin(f["origin"], f["where"])
        try:
            w = _number(f["width"], f"{f['where']}: width_m")
            h = _number(f["height"], f"{f['where']}: height_m")
        except ValueError as exc:
            raise GisError([str(exc)]) from None
        notes.append(f"origin and area from {f['where']}")
        return o, w, h, True, notes
    data = _all_lonlat(layers)
    if not len(data):
        raise GisError(["no features: nothing to build a map from"])
    alt = origin[2] if origin is not None else (home_alt if home_alt is not None else 0.0)
    provisional = origin or (float(data[:, 1].min()), float(data[:, 0].min()), alt)
    if layers.areas or layers.area_circles:
        # the inclusion fences (or area polygons) bound the area: their intersection's box
        regions = _inclusion_regions(layers, provisional)
        if all(g is not None for _, g, _ in regions):
            lo, hi = (np.array(v) for v in np.reshape(_allowed(regions).bounds, (2, 2)))
        else:  # a polygon that is not simple: build_map names it
            pts = [_local(p.rings[0], provisional) for p in layers.areas]
            pts += [_circle_bounds(c, provisional) for c in layers.area_circles]
            xy = np.concatenate(pts)
            lo, hi = xy.min(axis=0), xy.max(axis=0)
        given = True
    else:
        xy = _local(data, provisional)
        for c in layers.circles:
            xy = np.vstack([xy, _circle_bounds(c, provisional)])
        lo, hi = xy.min(axis=0) - margin, xy.max(axis=0) + margin
        given = False
    if origin is None:
        lat, lon = enu_to_latlon(lo[0], lo[1], provisional)
        o = (round(float(lat), 9), round(float(lon), 9), alt)
        notes.append(f"origin (lat {o[0]:.9f}, lon {o[1]:.9f}): the south-west corner of the "
                     + ("area" if given else f"data's bounds grown by {margin:g} m"))  # fmt: skip
        if home_alt is not None:
            notes.append(f"origin altitude {home_alt:g} m from {layers.home['where']}")
        w, h = float(hi[0] - lo[0]), float(hi[1] - lo[1])
    else:
        o = origin
        w, h = float(hi[0]), float(hi[1])
    from planner_core.model.mapio import MAX_SIDE

    if w > MAX_SIDE or h > MAX_SIDE:  # a stray feature far from the others, usually
        lon, lat = data[:, 0], data[:, 1]
        stray = _stray(layers, MAX_SIDE)
        raise GisError([f"the features lie too far apart for one map (longitude "
                        f"{lon.min():.6f} to {lon.max():.6f}, latitude {lat.min():.6f} to "
                        f"{lat.max():.6f}; a map's side is at most {MAX_SIDE / 1000:g} km): "
                        + (stray or "is one feature far from the others?")])
    # round the area outward to the centimetre
    w, h = math.ceil(w * 100.0) / 100.0, math.ceil(h * 100.0) / 100.0
    if not (w > 0 and h > 0):
        raise GisError([f"the area would be {w:g} m x {h:g} m: the data lie south or west of "
                        "the origin"])  # fmt: skip
    return o, w, h, given, notes


def _clean_shape(rings_xy: list[np.ndarray], where: str, notes: list[str],
                 locate: Any) -> tuple[np.ndarray, list[np.ndarray]] | str:
    """The feature's rings cleaned and oriented (`planner_core.model.polygons.clean_polygon`), or
    the
    problem as one line naming the feature."""
    from planner_core.model.polygons import clean_polygon

    try:
        shell, holes, said = clean_polygon(rings_xy, locate=locate)
    except ValueError as exc:
        return f"{where}: {exc}"
    notes += [f"{where}: {n}" for n in said if not n.startswith("given clockwise")]
    return shell, holes


def build_map(
    layers: GisLayers,
    *,
    origin: tuple[float, float, float | None] | None = None,
    margin: float = DEFAULT_MARGIN,
    name: str | None = None,
    default_name: str = "imported",
) -> tuple[dict[str, Any], list[str]]:
    """The map file (a dict for `planner_core.load_map`) and notes on what was done.

    Args:
        layers: what `read_layers` read.
        origin: (lat, lon, alt) of the local (0, 0); None: the exported area's frame, else the
            south-west corner of the area or the data's bounds. An alt of None takes the
            QGroundControl planned home's altitude (else 0).
        margin: metres of area around the data when no area is given.
        name: the map's name; None: the name an exported area feature carries, else
            `default_name`.
        default_name: the name when neither `name` nor the inputs give one.

    Returns:
        (map document, notes): the document keeps the settings (uav, radio, objective, safety,
        fleet, witness) an exported area feature carries; absent ones take the map defaults.

    Raises:
        GisError: every problem found, one line each, naming file and feature.
    """
    import shapely
    from shapely.geometry import Polygon, box

    from planner_core.model.geometry import rectangle_vertices

    if not (margin >= 0 and math.isfinite(margin)):
        raise GisError([f"--margin must be a finite number >= 0 (got {margin:g})"])
    o, W, H, area_given, notes = _frame(layers, origin, margin)
    problems: list[str] = []
    area_box = box(0.0, 0.0, W, H)

    def locate(x: float, y: float) -> str:
        lat, lon = enu_to_latlon(x, y, o)
        return f"lon {float(lon):.6f}, lat {float(lat):.6f}"

    def point(e: dict[str, Any], label: str) -> list[float] | None:
        (x, y), = _local([(e["lon"], e["lat"])], o)
        if not (0.0 <= x <= W and 0.0 <= y <= H):
            problems.append(f"{e['where']}: {label} ({_lonlat(e)}) is outside the area")
            return None
        return [round(float(x), 4), round(float(y), 4)]

    sensors = []
    seen: set[str] = set()
    for j, s in enumerate(layers.sensors):
        xy = point(s, "sensor")
        sid = s["id"] if s["id"] is not None else f"s{j + 1}"
        if sid in seen:
            problems.append(f"{s['where']}: duplicate sensor id '{sid}'")
        seen.add(sid)
        if xy is not None:
            entry: dict[str, Any] = {"id": sid, "x": xy[0], "y": xy[1]}
            if s["required_data"] is not None:
                entry["required_data"] = float(s["required_data"])
            sensors.append(entry)
    if not layers.sensors:
        problems.append("no sensors: add Point features with kind 'sensor' (or --sensors FILE)")
    start_src = layers.start or layers.home
    end_src = layers.end or layers.home
    if start_src is None:
        problems.append("no start: add a Point feature with kind 'start' (or a QGroundControl "
                        "plan with a planned home position)")  # fmt: skip
    if end_src is None:
        problems.append("no end: add a Point feature with kind 'end'")
    start = point(start_src, "start") if start_src else None
    end = point(end_src, "end") if end_src else None
    if layers.start is None and layers.home is not None:
        notes.append(f"start and end default to {layers.home['where']}")

    def shapes(polys: list[_Poly]) -> list[dict[str, Any]]:
        out: list[dict[str, Any]] = []
        for p in polys:
            rings_xy = [_local(r, o) for r in p.rings]
            cleaned = _clean_shape(rings_xy, p.where, notes, locate)
            if isinstance(cleaned, str):
                problems.append(cleaned)
                continue
            shell, holes = cleaned
            geom = Polygon(shell, holes)
            if not area_box.contains(geom):
                clipped = geom.intersection(area_box)
                parts = [g for g in shapely.get_parts(clipped) if g.geom_type == "Polygon"
                         and g.area > 0.0]  # fmt: skip
                if not parts:
                    notes.append(f"{p.where}: outside the area; dropped")
                    continue
                # the farthest point of a polygon from the (convex) area is one of its vertices
                reach = max(area_box.distance(shapely.Point(v)) for v in shell)
                if reach > CLIP_TOLERANCE:  # on the edge within the tolerance: no clip to tell
                    notes.append(f"{p.where}: clipped to the area (it reached {reach:.2f} m "
                                 "outside)")  # fmt: skip
                for g in parts:
                    ring_sets = [np.asarray(g.exterior.coords)]
                    ring_sets += [np.asarray(h.coords) for h in g.interiors]
                    c2 = _clean_shape(ring_sets, p.where, notes, locate)
                    if isinstance(c2, str):
                        problems.append(c2)
                        continue
                    out.append(_entry(c2, p.name))
                continue
            out.append(_entry(cleaned, p.name))
        return out

    rectangles: list[dict[str, Any]] = []
    drawn: list[_Poly] = []  # rectangles whose outline no longer matches their properties
    for r in layers.rectangles:
        (x, y), = _local([(r["lon"], r["lat"])], o)
        corners = rectangle_vertices(x, y, r["length"], r["width"], r["angle"])
        outline = Polygon(_local(r["poly"].rings[0], o))
        off = outline.hausdorff_distance(Polygon(corners))
        if off > RECTANGLE_TOLERANCE:
            notes.append(f"{r['where']}: its outline is {off:.2f} m from the rectangle its "
                         "properties describe; imported as the outline drawn")  # fmt: skip
            drawn.append(r["poly"])
        elif max(area_box.distance(shapely.Point(v)) for v in corners) > CLIP_TOLERANCE:
            drawn.append(r["poly"])  # partly outside: clipped as a polygon (noted there)
        else:
            rectangles.append({"x": round(float(x), 4), "y": round(float(y), 4),
                               "length": r["length"], "width": r["width"],
                               "angle_deg": r["angle"]})  # fmt: skip
    obstacles = shapes(drawn + layers.obstacles)
    zones = shapes(layers.no_fly_zones)
    circles = []
    for c in layers.circles:
        (x, y), = _local([(c["lon"], c["lat"])], o)
        if not (0.0 <= x <= W and 0.0 <= y <= H):
            problems.append(f"{c['where']}: circle centre ({_lonlat(c)}) is outside the area")
            continue
        circles.append({"x": round(float(x), 4), "y": round(float(y), 4), "radius": c["radius"]})
    if area_given and (layers.areas or layers.area_circles):
        _inclusion_zones(layers, o, area_box, zones, notes, problems, locate)
    settings = _settings(layers, o, notes)
    if layers.depots:
        _depot_features(layers, settings, point, notes, problems)
    if problems:
        raise GisError(problems)
    given_name = settings.pop("name", None)
    doc: dict[str, Any] = {
        "name": name if name is not None else (given_name or default_name),
        "origin": {"lat": o[0], "lon": o[1], "alt": o[2]},
        "area": {"width": W, "height": H},
        "start": start,
        "end": end,
        "sensors": sensors,
        "obstacles": {"circles": circles, "rectangles": rectangles, "no_fly_zones": zones,
                      "polygons": obstacles},  # fmt: skip
        **settings,
    }
    return doc, notes


def _inclusion_zones(layers: GisLayers, o: tuple[float, float, float], area_box: Any,
                     zones: list[dict[str, Any]], notes: list[str], problems: list[str],
                     locate: Any) -> None:  # fmt: skip
    """Add to `zones` the part of the area outside the inclusion region(s) (the intersection
    of several: INCLUSION_RULE), and say where the area came from in `notes`."""
    regions = _inclusion_regions(layers, o)
    bad = [name for name, g, _ in regions if g is None]
    if bad:
        problems += [f"{w}: the inclusion polygon is not simple" for w in bad]
        return
    try:
        allowed = _allowed(regions)
    except GisError as exc:
        problems += exc.problems
        return
    # GeoJSON `area` polygons alone are "area polygons"; with a QGroundControl fence, all fences
    what = "inclusion fence" if any(f for _, _, f in regions) else "area polygon"
    if len(regions) == 1:
        source = f"the {what} ({regions[0][0]})"
    else:
        names = ", ".join(name for name, _, _ in regions)
        notes.append(f"area: the intersection of the {len(regions)} {what}s ({names}), not "
                     f"their union: {INCLUSION_RULE}")
        source = "that intersection"
    label = f"outside the {what}"
    outside = area_box.difference(allowed)
    # morphological opening: slivers thinner than SLIVER_WIDTH between the box and the
    # fence (its edges are not exactly the frame's axes) go, mitred corners stay
    d = 0.5 * SLIVER_WIDTH
    opened = outside.buffer(-d, join_style="mitre", mitre_limit=10.0)
    opened = opened.buffer(d, join_style="mitre", mitre_limit=10.0).intersection(area_box)
    added = 0
    import shapely

    for g in shapely.get_parts(opened):
        if g.geom_type != "Polygon" or g.is_empty:
            continue
        rings = [np.asarray(g.exterior.coords)] + [np.asarray(h.coords) for h in g.interiors]
        c2 = _clean_shape(rings, label, notes, locate)
        if isinstance(c2, str):
            problems.append(c2)
            continue
        zones.append(_entry(c2, label))
        added += 1
    if layers.area_frame is not None:  # the area is the exported frame, not a bounding box
        if added:
            notes.append(f"area: from {layers.area_frame['where']}; the part of it outside "
                         f"{source} is a no-fly zone '{label}'")  # fmt: skip
        return
    said = f"area: the bounding box of {source}"
    if added:
        said += (f"; the part of it outside is a no-fly zone '{label}' (slivers thinner than "
                 f"{SLIVER_WIDTH * 100:g} cm left out)")
    notes.append(said)


def _settings(layers: GisLayers, o: tuple[float, float, float],
              notes: list[str]) -> dict[str, Any]:  # fmt: skip
    """The settings an exported area carries, with the local positions in them (fleet depots,
    witness hover points) moved to this map's frame when --origin moved it."""
    import copy

    if layers.settings is None:
        return {}
    settings = copy.deepcopy(layers.settings)
    sections = ", ".join(k for k in settings if k != "name") or "name"
    notes.append(f"map settings ({sections}) from {layers.settings_where}")
    if layers.settings_text:
        notes.append(f"{', '.join(layers.settings_text)}: read from JSON text (a GIS editor "
                     "saves nested properties as text)")
    if layers.area_frame is None:
        return settings
    src = _parse_origin(layers.area_frame["origin"], layers.area_frame["where"])
    if src == tuple(o):
        return settings

    def moved(pts: Any) -> Any:
        a = np.asarray(pts, dtype=float).reshape(-1, 2)
        lat, lon = enu_to_latlon(a[:, 0], a[:, 1], src)
        b = _local(np.column_stack([lon, lat]), o)
        return np.round(b, 4).tolist()

    try:
        # (depot features, when given, replace these: `_depot_features`)
        depots = [] if layers.depots else (settings.get("fleet") or {}).get("depots") or []
        xy = moved([[d["x"], d["y"]] for d in depots]) if depots else []
        for d, (x, y) in zip(depots, xy, strict=True):
            d["x"], d["y"] = x, y
        witness = settings.get("witness") or {}
        if witness.get("hover_points"):
            witness["hover_points"] = moved(witness["hover_points"])
    except (TypeError, KeyError, ValueError, AttributeError):
        return settings  # malformed: the map loader names the field
    what = [w for w, there in (("fleet depots", depots), ("witness hover points",
                                                          witness.get("hover_points"))) if there]
    if what:
        notes.append(f"{' and '.join(what)} moved with the frame to the new origin")
    return settings


def _depot_features(layers: GisLayers, settings: dict[str, Any], point: Any,
                    notes: list[str], problems: list[str]) -> None:  # fmt: skip
    """The ``depot`` features as `settings`' ``fleet.depots``, in their order (a fleet section
    made when the settings have none): they replace depots the carried fleet section gives (a
    note says so). `point` places a feature in the local frame (None, and a problem, when it
    lies outside the area); a duplicate name is a problem naming both features."""
    depots: list[dict[str, Any]] = []
    seen: dict[str, str] = {}
    for k, d in enumerate(layers.depots):
        name = d["name"] if d["name"] else f"d{k + 1}"
        if name in seen:
            problems.append(f"{d['where']}: duplicate depot name '{name}' (the first: "
                            f"{seen[name]})")  # fmt: skip
        seen.setdefault(name, d["where"])
        xy = point(d, "depot")
        if xy is not None:
            depots.append({"name": name, "x": xy[0], "y": xy[1]})
    fleet = settings.get("fleet")
    if not isinstance(fleet, dict):
        fleet = settings["fleet"] = {}
    elif fleet.get("depots"):
        n = len(layers.depots)
        notes.append(f"fleet.depots: the {counted(n, 'depot feature')} "
                     f"{for_count(n, 'replaces', 'replace')} the {len(fleet['depots'])} in the "
                     "fleet settings of "
                     f"{layers.settings_where}")
    fleet["depots"] = depots


def _entry(shape: tuple[np.ndarray, list[np.ndarray]], name: str | None) -> dict[str, Any]:
    shell, holes = shape
    e: dict[str, Any] = {"vertices": np.round(shell, 4).tolist()}
    if holes:
        e["holes"] = [np.round(h, 4).tolist() for h in holes]
    if name is not None:
        e["name"] = name
    return e

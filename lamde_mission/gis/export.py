"""A map as GeoJSON (RFC 7946), for a GIS, and readable back by `lamde-mission map from-geojson`.

Every feature has the `kind` property the importer reads: "area" (Polygon; properties `origin`
[lat, lon, alt], `width_m`, `height_m`: the importer takes the frame from them, so a round trip
keeps the local coordinates; and the map's settings, every top-level section of the map file
that is not geometry (`SETTINGS_EXCLUDED` lists the geometric ones): `name`, `uav`, `radio`,
`objective`, `safety`, and `fleet` and `witness` when the map has them, each as the map file
writes it, so `map from-geojson` restores them; the fleet without its `depots`, which are
features of their own), "depot" (Point; `name`, `index`: one per `fleet.depots` entry, in
order, so a GIS shows and moves them), "sensor" (Point; `id`, `required_data` when the
map sets it), "obstacle" (Polygon with holes, for polygon obstacles and rectangles; `name`;
rectangles also `shape`: "rectangle", `center` [lon, lat], `length_m`, `width_m`, `angle_deg`:
the importer reads the rectangle back from those while the outline still matches them),
"no_fly_zone" (Polygon with holes; `name`), "circle" (a Polygon through `CIRCLE_SEGMENTS`
points of the circle for display, with `center` [lon, lat] and `radius_m`: the importer reads
the circle from those), "start" and "end" (Points), then the depots.
Rings are closed, exteriors counter-clockwise and holes clockwise (RFC 7946 Sec. 3.1.6).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from sim.geo import enu_to_latlon

__all__ = ["map_to_geojson", "map_features", "map_settings", "polygon_geometry",
           "CIRCLE_SEGMENTS", "SETTINGS_EXCLUDED"]

#: vertices of the polygon drawn for each circular obstacle
CIRCLE_SEGMENTS = 72
#: the map file's top-level sections written as features (or as the area feature's frame); every
#: other section is a setting, carried in the area feature's properties
SETTINGS_EXCLUDED = frozenset({"origin", "area", "start", "end", "sensors", "obstacles"})


def _lonlat(map_: Any, pts: np.ndarray) -> list[list[float]]:
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    lat, lon = enu_to_latlon(pts[:, 0], pts[:, 1], map_)
    return [[float(b), float(a)] for a, b in zip(lat, lon, strict=True)]


def _ring(map_: Any, ring: np.ndarray, ccw: bool) -> list[list[float]]:
    ring = np.asarray(ring, dtype=float).reshape(-1, 2)
    x, y = ring[:, 0], ring[:, 1]
    area2 = float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
    if (area2 > 0) != ccw:
        ring = ring[::-1]
    out = _lonlat(map_, ring)
    out.append(list(out[0]))
    return out


def polygon_geometry(map_: Any, shell: np.ndarray, holes: Any = ()) -> dict[str, Any]:
    """A GeoJSON Polygon (closed rings, exterior CCW, holes CW) of local rings (V, 2)."""
    rings = [_ring(map_, shell, True)] + [_ring(map_, h, False) for h in holes]
    return {"type": "Polygon", "coordinates": rings}


def _feature(geometry: dict[str, Any], **props: Any) -> dict[str, Any]:
    return {"type": "Feature", "geometry": geometry,
            "properties": {k: v for k, v in props.items() if v is not None}}  # fmt: skip


def map_settings(map: Any) -> dict[str, Any]:  # noqa: A002
    """The map's non-geometric top-level sections, as its map file writes them.

    Args:
        map: a loaded `planner_core.model.mapio.Map`.

    Returns:
        {section: value} for every section of `Map.to_dict()` not in `SETTINGS_EXCLUDED` and
        not null: name, uav, radio, objective, safety, and fleet and witness where given; the
        fleet without `depots` (written as "depot" features, in WGS84 like every position).
    """
    out = {k: v for k, v in map.to_dict().items()
           if k not in SETTINGS_EXCLUDED and v is not None}  # fmt: skip
    if isinstance(out.get("fleet"), dict):  # the depots are features (`map_features`)
        out["fleet"] = {k: v for k, v in out["fleet"].items() if k != "depots"}
    return out


def map_features(map: Any) -> list[dict[str, Any]]:  # noqa: A002
    """The map as GeoJSON features: area (with the frame and settings), circles, rectangles,
    polygon obstacles, no-fly zones, sensors, start, end and the fleet's depots.

    Args:
        map: a loaded `planner_core.model.mapio.Map` with an origin.

    Returns:
        The features, in that order (see the module docstring for their properties).
    """
    spec = map.spec
    W, H = spec.area.width, spec.area.height
    o = spec.origin
    settings = map_settings(map)
    feats = [_feature(polygon_geometry(map, np.array([[0.0, 0.0], [W, 0.0], [W, H], [0.0, H]])),
                      kind="area", name=settings.pop("name", None),
                      origin=[o.lat, o.lon, o.alt], width_m=W, height_m=H,
                      **settings)]  # fmt: skip
    ang = np.linspace(0.0, 2.0 * math.pi, CIRCLE_SEGMENTS, endpoint=False)
    for k, c in enumerate(spec.obstacles.circles):
        ring = np.column_stack([c.x + c.radius * np.cos(ang), c.y + c.radius * np.sin(ang)])
        feats.append(_feature(polygon_geometry(map, ring), kind="circle", index=k,
                              radius_m=c.radius,
                              center=_lonlat(map, np.array([c.x, c.y]))[0]))  # fmt: skip
    for k, (r, poly) in enumerate(zip(spec.obstacles.rectangles, map.rectangle_polygons,
                                      strict=True)):  # fmt: skip
        feats.append(_feature(polygon_geometry(map, poly), kind="obstacle", shape="rectangle",
                              index=k, length_m=r.length, width_m=r.width, angle_deg=r.angle_deg,
                              center=_lonlat(map, np.array([r.x, r.y]))[0]))  # fmt: skip
    for sh in map.shapes:
        kind = "no_fly_zone" if sh.kind == "no_fly_zone" else "obstacle"
        feats.append(_feature(polygon_geometry(map, sh.shell, sh.holes), kind=kind, name=sh.name,
                              index=sh.index))  # fmt: skip
    for s in spec.sensors:
        feats.append(_feature({"type": "Point", "coordinates": _lonlat(map, [s.x, s.y])[0]},
                              kind="sensor", id=s.id, required_data=s.required_data))  # fmt: skip
    for kind in ("start", "end"):
        p = getattr(map, kind)
        feats.append(_feature({"type": "Point", "coordinates": _lonlat(map, p)[0]}, kind=kind))
    depots = spec.fleet.depots if spec.fleet is not None and spec.fleet.depots else ()
    for k, d in enumerate(depots):
        feats.append(_feature({"type": "Point", "coordinates": _lonlat(map, [d.x, d.y])[0]},
                              kind="depot", name=d.name, index=k))  # fmt: skip
    return feats


def map_to_geojson(map: Any) -> dict[str, Any]:  # noqa: A002
    """The map as a GeoJSON FeatureCollection (WGS84 [lon, lat]); see the module docstring.

    Args:
        map: a loaded `planner_core.model.mapio.Map` with an origin.

    Returns:
        The FeatureCollection, JSON-ready; `map from-geojson` reads it back to the same map.
    """
    return {"type": "FeatureCollection", "features": map_features(map)}

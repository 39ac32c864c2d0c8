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

from planner_core.model.polygons import ring_area
from sim.geo import enu_to_latlon

__all__ = ["map_to_geojson", "map_features", "map_settings", "polygon_geometry", "lonlat",
           "linear_ring", "circle_ring", "feature", "CIRCLE_SEGMENTS", "SETTINGS_EXCLUDED"]

#: vertices of the polygon drawn for each circular obstacle
CIRCLE_SEGMENTS = 72
#: the map file's top-level sections written as features (or as the area feature's frame); every
#: other section is a setting, carried in the area feature's properties
SETTINGS_EXCLUDED = frozenset({"origin", "area", "start", "end", "sensors", "obstacles"})


def lonlat(map_: Any, pts: Any) -> list[list[float]]:
    """Local points as GeoJSON positions.

    Args:
        map_: a loaded `planner_core.model.mapio.Map` with an origin.
        pts: local ENU points, metres: anything of 2k numbers, read as (k, 2).

    Returns:
        k positions [longitude, latitude] (WGS84 degrees), in the order of `pts`.
    """
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    lat, lon = enu_to_latlon(pts[:, 0], pts[:, 1], map_)
    return [[float(b), float(a)] for a, b in zip(lat, lon, strict=True)]


def linear_ring(map_: Any, ring: Any, ccw: bool = True) -> list[list[float]]:
    """A closed GeoJSON linear ring of a local vertex cycle, turned the asked way.

    Args:
        map_: a loaded `planner_core.model.mapio.Map` with an origin.
        ring: the cycle's vertices (V, 2), local metres, without the closing vertex.
        ccw: counter-clockwise (an exterior, RFC 7946 Sec. 3.1.6) or clockwise (a hole).

    Returns:
        V + 1 positions [lon, lat]: the vertices, reversed when their signed area
        (`planner_core.model.polygons.ring_area`) says the other way, then the first again.
    """
    ring = np.asarray(ring, dtype=float).reshape(-1, 2)
    if (ring_area(ring) > 0) != ccw:
        ring = ring[::-1]
    out = lonlat(map_, ring)
    out.append(list(out[0]))
    return out


def circle_ring(x: float, y: float, radius: float) -> np.ndarray:
    """The polygon drawn for a circle: `CIRCLE_SEGMENTS` points on it (a GeoJSON has no circle).

    Args:
        x, y: the centre, local metres.
        radius: metres.

    Returns:
        (CIRCLE_SEGMENTS, 2) local points, counter-clockwise from angle 0 (east).
    """
    ang = np.linspace(0.0, 2.0 * math.pi, CIRCLE_SEGMENTS, endpoint=False)
    return np.column_stack([x + radius * np.cos(ang), y + radius * np.sin(ang)])


def polygon_geometry(map_: Any, shell: np.ndarray, holes: Any = ()) -> dict[str, Any]:
    """A GeoJSON Polygon (closed rings, exterior CCW, holes CW) of local rings (V, 2).

    Args:
        map_: a loaded `planner_core.model.mapio.Map` with an origin.
        shell: the exterior ring (V, 2), local metres, without the closing vertex.
        holes: the hole rings, each (V, 2), local metres.

    Returns:
        {"type": "Polygon", "coordinates": rings}, the exterior first, positions [lon, lat].
    """
    rings = [linear_ring(map_, shell, True)] + [linear_ring(map_, h, False) for h in holes]
    return {"type": "Polygon", "coordinates": rings}


def feature(geometry: dict[str, Any], /, keep_none: bool = False, **props: Any) -> dict[str, Any]:
    """A GeoJSON Feature.

    Args:
        geometry: its GeoJSON geometry object.
        keep_none: keep properties whose value is None (written as null); by default they are
            left out, as the map's features leave out what the map does not set.
        **props: its properties, in the order given.

    Returns:
        {"type": "Feature", "geometry": geometry, "properties": props}.
    """
    if not keep_none:
        props = {k: v for k, v in props.items() if v is not None}
    return {"type": "Feature", "geometry": geometry, "properties": props}


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
    feats = [feature(polygon_geometry(map, np.array([[0.0, 0.0], [W, 0.0], [W, H], [0.0, H]])),
                     kind="area", name=settings.pop("name", None),
                     origin=[o.lat, o.lon, o.alt], width_m=W, height_m=H,
                     **settings)]  # fmt: skip
    for k, c in enumerate(spec.obstacles.circles):
        feats.append(feature(polygon_geometry(map, circle_ring(c.x, c.y, c.radius)),
                             kind="circle", index=k, radius_m=c.radius,
                             center=lonlat(map, np.array([c.x, c.y]))[0]))  # fmt: skip
    for k, (r, poly) in enumerate(zip(spec.obstacles.rectangles, map.rectangle_polygons,
                                      strict=True)):  # fmt: skip
        feats.append(feature(polygon_geometry(map, poly), kind="obstacle", shape="rectangle",
                             index=k, length_m=r.length, width_m=r.width, angle_deg=r.angle_deg,
                             center=lonlat(map, np.array([r.x, r.y]))[0]))  # fmt: skip
    for sh in map.shapes:
        kind = "no_fly_zone" if sh.kind == "no_fly_zone" else "obstacle"
        feats.append(feature(polygon_geometry(map, sh.shell, sh.holes), kind=kind, name=sh.name,
                             index=sh.index))  # fmt: skip
    for s in spec.sensors:
        feats.append(feature({"type": "Point", "coordinates": lonlat(map, [s.x, s.y])[0]},
                             kind="sensor", id=s.id, required_data=s.required_data))  # fmt: skip
    for kind in ("start", "end"):
        p = getattr(map, kind)
        feats.append(feature({"type": "Point", "coordinates": lonlat(map, p)[0]}, kind=kind))
    depots = spec.fleet.depots if spec.fleet is not None and spec.fleet.depots else ()
    for k, d in enumerate(depots):
        feats.append(feature({"type": "Point", "coordinates": lonlat(map, [d.x, d.y])[0]},
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

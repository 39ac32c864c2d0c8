"""GeoJSON (RFC 7946) view of a plan on its map, for GIS tools and web maps.

A FeatureCollection in WGS84 with [longitude, latitude] positions. Every feature has a
`kind` property: "area", "circle", "rectangle", "no_fly_zone", "obstacle" (polygon footprints)
(Polygons: closed rings, exterior counter-clockwise, holes clockwise; circles approximated by a
regular polygon through the circle,
with `centre` and `radius` kept as properties), "sensor" (Point: id, required, collected),
"path" (LineString start -> hover points and corners -> end), "hover" (Point: index,
hover_time), "corner" (Point: index; a point of 0 s, written as a NAV_WAYPOINT flown through,
not a hover point; `index` counts hover points and corners together, in flying order),
"start" and "end" (Points). Export only: a GeoJSON file is not read back as a mission.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from lamde_mission.atomic import write_text_atomic
from lamde_mission.gis.export import (
    CIRCLE_SEGMENTS,
    circle_ring,
    feature,
    linear_ring,
    lonlat,
    polygon_geometry,
)
from lamde_mission.items import fence_shapes

__all__ = ["geojson_document", "write_geojson", "CIRCLE_SEGMENTS"]


def _feature(geometry: dict[str, Any], **props: Any) -> dict[str, Any]:
    """A plan's feature: its properties all kept, None as null (`feature`)."""
    return feature(geometry, keep_none=True, **props)


def _clean(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def geojson_document(plan: Any, map: Any) -> dict[str, Any]:  # noqa: A002
    """The FeatureCollection for `plan` (hover points, times, breakdown) on `map`.

    Args:
        plan: a `Plan`, or anything with `hover_points` (I, 2) m and `hover_times` (I,) s;
            `f`, `feasible` and `breakdown` (its `collected` Mbit by sensor id, `t_fly`,
            `t_hover` s) are read where present.
        map: the map, with an origin.

    Returns:
        The GeoJSON FeatureCollection (WGS84, [lon, lat]), features in the order: area,
        circles, rectangles, no-fly zones and polygon footprints, sensors, path, hover points
        and corners, start, end. Non-finite numbers are null.

    Raises:
        MissingOriginError: the map has no origin.
    """
    spec = map.spec
    feats: list[dict[str, Any]] = []
    w, h = spec.area.width, spec.area.height
    area = np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]])
    feats.append(_feature({"type": "Polygon", "coordinates": [linear_ring(map, area)]},
                          kind="area", width_m=w, height_m=h, name=spec.name))  # fmt: skip
    circles, _ = fence_shapes(map)
    for k, (centre, r) in enumerate(circles):
        ring = circle_ring(centre[0], centre[1], r)
        feats.append(_feature(
            {"type": "Polygon", "coordinates": [linear_ring(map, ring)]},
            kind="circle", index=k, radius=r, centre=lonlat(map, centre)[0],
            centre_local=[float(centre[0]), float(centre[1])],
        ))  # fmt: skip
    for k, (r, poly) in enumerate(zip(spec.obstacles.rectangles, map.rectangle_polygons,
                                      strict=True)):  # fmt: skip
        feats.append(_feature({"type": "Polygon", "coordinates": [linear_ring(map, poly)]},
                              kind="rectangle", index=k, length=r.length, width=r.width,
                              angle_deg=r.angle_deg,
                              centre=lonlat(map, np.array([r.x, r.y]))[0]))  # fmt: skip
    for sh in map.shapes:  # no-fly zones and polygon footprints, holes kept
        props: dict[str, Any] = {"kind": "no_fly_zone" if sh.kind == "no_fly_zone"
                                 else "obstacle", "index": sh.index}  # fmt: skip
        if sh.name is not None:
            props["name"] = sh.name
        feats.append(_feature(polygon_geometry(map, sh.shell, sh.holes), **props))
    bd = getattr(plan, "breakdown", None) or {}
    collected = bd.get("collected", {}) if isinstance(bd, dict) else {}
    required = map.required_data
    for j, s in enumerate(spec.sensors):
        got = collected.get(s.id)
        feats.append(_feature(
            {"type": "Point", "coordinates": lonlat(map, np.array([s.x, s.y]))[0]},
            kind="sensor", id=s.id, required=float(required[j]),
            collected=_clean(float(got)) if got is not None else None,
            satisfied=(bool(got >= required[j]) if got is not None else None),
        ))  # fmt: skip
    hp = np.asarray(plan.hover_points, dtype=float).reshape(-1, 2)
    ht = np.asarray(plan.hover_times, dtype=float).reshape(-1)
    nodes = np.vstack([map.start, hp, map.end])
    feats.append(_feature(
        {"type": "LineString", "coordinates": lonlat(map, nodes)},
        kind="path", n_hover=int(np.count_nonzero(ht != 0.0)),
        n_corner=int(np.count_nonzero(ht == 0.0)),
        f=_clean(float(getattr(plan, "f", math.nan))),
        t_fly=_clean(bd.get("t_fly")), t_hover=_clean(bd.get("t_hover")),
        feasible=getattr(plan, "feasible", None),
    ))  # fmt: skip
    for i, (p, t) in enumerate(zip(hp, ht, strict=True)):
        point = {"type": "Point", "coordinates": lonlat(map, p)[0]}
        if float(t) == 0.0:  # a corner (items.plan_to_items writes it as NAV_WAYPOINT)
            feats.append(_feature(point, kind="corner", index=i))
        else:
            feats.append(_feature(point, kind="hover", index=i, hover_time=float(t)))
    for kind, p in (("start", map.start), ("end", map.end)):
        feats.append(_feature({"type": "Point", "coordinates": lonlat(map, p)[0]}, kind=kind))
    return {"type": "FeatureCollection", "features": feats}


def write_geojson(path: str | Path, plan: Any, map: Any) -> Path:  # noqa: A002
    """Write the GeoJSON view atomically.

    Args:
        path: the file to write.
        plan: the plan (`geojson_document`).
        map: the map, with an origin.

    Returns:
        The path written.

    Raises:
        MissingOriginError: the map has no origin.
    """
    doc = geojson_document(plan, map)
    return write_text_atomic(path, json.dumps(doc, indent=1, allow_nan=False) + "\n")

"""Local map metres (x east, y north) <-> WGS84 latitude/longitude through the map's origin.

Part of the sim's mission vocabulary: `lamde_mission` writes plans through it (re-exported as
`lamde_mission.geo`) and the sim reads missions back through it.

The planner works on a flat local frame; missions need latitude and longitude. A map point
(x, y) is the point on the surface at the origin's height whose east/north coordinates in the
origin's ENU frame are (x, y) (pymap3d, WGS84 ellipsoid). Altitudes in our missions are relative
to home (MAV_FRAME_GLOBAL_RELATIVE_ALT), so only the horizontal position goes through here.

Why the "surface at the origin's height": the inverse must work from latitude and longitude
alone (a mission file has no ENU up-coordinate). Using the plane u = 0 instead would drift by
several centimetres at 10 km, because the ENU plane rises above the ellipsoid away from the origin.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pymap3d

__all__ = [
    "MissingOriginError", "enu_to_latlon", "latlon_to_enu", "origin_of"]

_ITERATIONS = 4


class MissingOriginError(ValueError):
    """A map without an `origin`: its local metres have no place on Earth, so no mission
    (latitude/longitude) can be made from it or read onto it."""


def origin_of(map_or_origin: Any) -> tuple[float, float, float]:
    """(lat, lon, alt) of a Map, a MapFile, an Origin model or a 3-tuple.

    Args:
        map_or_origin: a Map or MapFile (read through its `spec` and `origin`), an Origin
            model (`lat`, `lon`, `alt`) or a (lat, lon[, alt]) sequence: degrees, degrees, m.

    Returns:
        (lat, lon, alt) as floats: degrees, degrees, metres (0.0 when not given).

    Raises:
        MissingOriginError: a map has none (no default place is ever assumed).
    """
    obj = map_or_origin
    if hasattr(obj, "spec"):
        obj = obj.spec
    if hasattr(obj, "origin"):
        obj = obj.origin
        if obj is None:
            raise MissingOriginError(
                "origin: the map has no origin (the latitude/longitude of its (0, 0)); add "
                '"origin": {"lat": ..., "lon": ..., "alt": ...} to the map or pass '
                "--origin LAT,LON[,ALT]"
            )
    if hasattr(obj, "lat"):
        return float(obj.lat), float(obj.lon), float(getattr(obj, "alt", 0.0))
    lat, lon, *rest = obj
    return float(lat), float(lon), float(rest[0]) if rest else 0.0


def enu_to_latlon(x: Any, y: Any, origin: Any) -> tuple[np.ndarray, np.ndarray]:
    """Latitude and longitude (degrees) of local points (x east, y north, metres).

    Args:
        x: east, metres; a scalar or an array.
        y: north, metres; a scalar or an array (broadcast against `x`).
        origin: the map's origin, anything `origin_of` reads.

    Returns:
        (lat, lon), degrees: float64 arrays of the broadcast shape.

    Raises:
        MissingOriginError: `origin` is a map without an origin.
    """
    lat0, lon0, h0 = origin_of(origin)
    e = np.asarray(x, dtype=float)
    n = np.asarray(y, dtype=float)
    e, n = np.broadcast_arrays(e, n)
    u = np.zeros_like(e)
    # Find the up-coordinate putting the point at height h0: the local vertical is within a
    # fraction of a degree of the origin's, so each step shrinks the height error ~1e5 times.
    for _ in range(_ITERATIONS):
        lat, lon, h = pymap3d.enu2geodetic(e, n, u, lat0, lon0, h0)
        u = u - (np.asarray(h) - h0)
    lat, lon, _ = pymap3d.enu2geodetic(e, n, u, lat0, lon0, h0)
    return np.asarray(lat, dtype=float), np.asarray(lon, dtype=float)


def latlon_to_enu(lat: Any, lon: Any, origin: Any) -> tuple[np.ndarray, np.ndarray]:
    """Local (x east, y north) metres of latitude/longitude points (inverse of `enu_to_latlon`).

    Args:
        lat: latitude, degrees; a scalar or an array.
        lon: longitude, degrees; a scalar or an array (broadcast against `lat`).
        origin: the map's origin, anything `origin_of` reads.

    Returns:
        (x, y), metres east and north: float64 arrays of the broadcast shape.

    Raises:
        MissingOriginError: `origin` is a map without an origin.
    """
    lat0, lon0, h0 = origin_of(origin)
    la = np.asarray(lat, dtype=float)
    lo = np.asarray(lon, dtype=float)
    la, lo = np.broadcast_arrays(la, lo)
    e, n, _ = pymap3d.geodetic2enu(la, lo, np.full(la.shape, h0), lat0, lon0, h0)
    return np.asarray(e, dtype=float), np.asarray(n, dtype=float)

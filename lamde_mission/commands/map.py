"""`lamde-mission map from-geojson|to-geojson`: real maps in (GeoJSON, QGroundControl) and out."""

from __future__ import annotations

import argparse
import sys

from lamde_mission.errors import UsageError


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "map",
        help="import a map from GeoJSON / QGroundControl layers, or export one as GeoJSON",
        description="Convert between GIS layers (WGS84) and the planner's map file (local "
        "metres). `map from-geojson FILE... -o map.json`; `map to-geojson MAP -o map.geojson`.",
    )
    msub = p.add_subparsers(dest="map_command", metavar="SUBCOMMAND", required=True)
    fg = msub.add_parser(
        "from-geojson",
        help="GeoJSON layers (and QGroundControl .plan geofences) -> a map file",
        description="Read GeoJSON FeatureCollections whose features say their layer in a `kind` "
        "property (sensor [id, required_data], obstacle or building, no_fly_zone, start, end, "
        "area, circle) and QGroundControl .plan files (exclusion fences become no-fly zones and "
        "circular obstacles, the inclusion fence the area, the planned home the start and end). "
        "Coordinates are WGS84 (RFC 7946). Origin: --origin, else the south-west corner of the "
        "data's bounds grown by --margin. Polygons may be non-convex, with holes; rings are "
        "cleaned (closing, duplicate and collinear vertices within 5 mm) and self-intersections "
        "refused naming the feature. Obstacles partly outside the area are clipped to it.",
    )
    fg.add_argument("files", nargs="*", metavar="FILE", help="GeoJSON or QGroundControl .plan")
    fg.add_argument("--obstacles", action="append", default=[], metavar="FILE",
                    help="a GeoJSON file whose every feature is an obstacle (repeatable)")
    fg.add_argument("--no-fly-zones", action="append", default=[], metavar="FILE",
                    help="a GeoJSON file whose every feature is a no-fly zone (repeatable)")
    fg.add_argument("--sensors", action="append", default=[], metavar="FILE",
                    help="a GeoJSON file whose every feature is a sensor (repeatable)")
    fg.add_argument("--origin", metavar="LAT,LON[,ALT]",
                    help="WGS84 origin of the local frame (default: south-west corner of the "
                    "data's bounds grown by --margin)")
    fg.add_argument("--margin", default="100", metavar="M",
                    help="metres of area around the data when the area is not given (default 100)")
    fg.add_argument("--name", help="map name (default: the first input's file name)")
    fg.add_argument("-o", "--output", required=True, help="map file to write (JSON)")
    tg = msub.add_parser(
        "to-geojson",
        help="a map file -> GeoJSON (WGS84), readable by GIS tools and by from-geojson",
        description="Write MAP as a GeoJSON FeatureCollection: area, obstacles (holes kept), "
        "no-fly zones, circles, sensors, start and end, each with a `kind` property.",
    )
    tg.add_argument("map", help="map file (JSON)")
    tg.add_argument("-o", "--output", required=True, help="GeoJSON file to write")
    cg = msub.add_parser(
        "campus",
        help="write a generated campus of non-convex footprints (a benchmark at real scale)",
        description="A seeded campus: N footprints (L, U, T shapes, blocks with a courtyard) on "
        "a grid of lots over a 5 km area, sensors in empty lots, start and end in the corners. "
        "The benchmarks use campus-500 at seed 0. The map is placed at --origin (default: the "
        "generated maps' fixed origin) so `plan` can write its missions in WGS84. "
        "Same seed, same bytes.",
    )
    cg.add_argument("--footprints", type=int, default=500, metavar="N", help="default 500")
    cg.add_argument("--sensors", type=int, default=15, metavar="N", help="default 15")
    cg.add_argument("--seed", type=int, default=0, help="default 0")
    cg.add_argument("--origin", metavar="LAT,LON[,ALT]",
                    help="WGS84 origin of the local frame (default 23.0493,113.3975,10, the "
                    "origin of every generated map)")
    cg.add_argument("-o", "--output", required=True, help="map file to write (JSON)")
    return p


def _origin(text: str | None) -> tuple[float, float, float] | None:
    if text is None:
        return None
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        raise UsageError(f"--origin must be LAT,LON[,ALT] in degrees (got {text!r})") from None
    if len(vals) not in (2, 3) or not (-90 <= vals[0] <= 90 and -180 <= vals[1] <= 180):
        raise UsageError(f"--origin must be LAT,LON[,ALT] in degrees (got {text!r})")
    return vals[0], vals[1], vals[2] if len(vals) == 3 else 0.0


def _from_geojson(args: argparse.Namespace) -> int:
    import json
    import math
    from pathlib import Path

    from lamde_mission.atomic import write_text_atomic
    from lamde_mission.gis import GisError, build_map, read_layers
    from planner_core.model.mapio import MapError, load_map

    inputs = [(f, None) for f in args.files]
    inputs += [(f, "obstacle") for f in args.obstacles]
    inputs += [(f, "no_fly_zone") for f in args.no_fly_zones]
    inputs += [(f, "sensor") for f in args.sensors]
    if not inputs:
        raise UsageError("give at least one input FILE (or --obstacles/--no-fly-zones/--sensors)")
    try:
        margin = float(args.margin)
    except ValueError:
        raise UsageError(f"--margin must be a number of metres (got {args.margin!r})") from None
    if not (math.isfinite(margin) and margin >= 0):
        raise UsageError(f"--margin must be a finite number >= 0 (got {args.margin!r})")
    name = args.name or Path(inputs[0][0]).stem
    try:
        layers = read_layers(inputs)
        doc, notes = build_map(layers, origin=_origin(args.origin), margin=margin, name=name)
    except GisError as exc:
        raise UsageError("\n".join(exc.problems)) from None
    try:
        m = load_map(doc)
    except MapError as exc:
        raise UsageError("\n".join(f"the imported map: {p}" for p in exc.problems)) from None
    for note in notes + list(m.notes):
        print(f"note: {note}", file=sys.stderr)
    try:
        path = write_text_atomic(args.output, json.dumps(m.to_dict(), indent=1) + "\n")
    except OSError as exc:
        raise UsageError(f"{args.output}: cannot write ({exc.strerror or exc})") from None
    s = m.summary()
    print(f"wrote {path}: {s['sensors']} sensors, {s['polygons']} obstacles, "
          f"{s['no_fly_zones']} no-fly zones, {s['circles']} circles; area "
          f"{m.width:g} m x {m.height:g} m from origin ({m.spec.origin.lat:.9f}, "
          f"{m.spec.origin.lon:.9f})")  # fmt: skip
    return 0


def _to_geojson(args: argparse.Namespace) -> int:
    import json

    from lamde_mission.atomic import write_text_atomic
    from lamde_mission.commands._common import load_map_or_fail
    from lamde_mission.gis import map_to_geojson

    m = load_map_or_fail(args.map)
    doc = map_to_geojson(m)
    try:
        path = write_text_atomic(args.output, json.dumps(doc, indent=1, allow_nan=False) + "\n")
    except OSError as exc:
        raise UsageError(f"{args.output}: cannot write ({exc.strerror or exc})") from None
    print(f"wrote {path}: {len(doc['features'])} features")
    return 0


def _campus(args: argparse.Namespace) -> int:
    from lamde_mission.atomic import write_text_atomic
    from lamde_mission.gis.synthetic import campus_map
    from planner_core.suite import SUITE_ORIGIN, dumps_map

    if args.seed < 0:
        raise UsageError(f"--seed must be >= 0 (got {args.seed})")
    given = _origin(args.origin)
    origin = (dict(SUITE_ORIGIN) if given is None
              else {"lat": given[0], "lon": given[1], "alt": given[2]})  # fmt: skip
    try:
        doc = campus_map(args.footprints, seed=args.seed, n_sensors=args.sensors)
    except ValueError as exc:
        raise UsageError(f"--footprints/--sensors: {exc}") from None
    # every generated map carries an origin (plan writes WGS84 missions from it): name first
    doc = {"name": doc.pop("name"), "origin": origin, **doc}
    try:
        path = write_text_atomic(args.output, dumps_map(doc))
    except OSError as exc:
        raise UsageError(f"{args.output}: cannot write ({exc.strerror or exc})") from None
    print(f"wrote {path}: {args.footprints} footprints, {args.sensors} sensors, origin "
          f"({origin['lat']}, {origin['lon']})")
    return 0


def run(args: argparse.Namespace) -> int:
    if args.map_command == "from-geojson":
        return _from_geojson(args)
    if args.map_command == "campus":
        return _campus(args)
    return _to_geojson(args)

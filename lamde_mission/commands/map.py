"""`lamde-mission map from-geojson|to-geojson|campus`: real maps in (GeoJSON, QGroundControl)
and out, and a generated campus of building footprints (a benchmark map at real scale)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from lamde_mission.errors import UsageError
from planner_core import defaults as D


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `lamde-mission map` and its subcommands from-geojson, to-geojson and campus
    (options, help).

    Args:
        sub: the subcommands of `lamde_mission.cli.build_parser`.

    Returns:
        The command's parser (`build_parser` sets `run` as its `_run`).
    """
    p = sub.add_parser(
        "map",
        help="import a map from GeoJSON / QGroundControl layers, export one as GeoJSON, or "
        "generate a campus",
        description="Convert between GIS layers (WGS84) and the planner's map file (local "
        "metres), or generate a campus of building footprints. `map from-geojson FILE... -o "
        "map.json`; `map to-geojson MAP -o map.geojson`; `map campus -o campus.json`.",
    )
    msub = p.add_subparsers(dest="map_command", metavar="SUBCOMMAND", required=True)
    fg = msub.add_parser(
        "from-geojson",
        help="GeoJSON layers (and QGroundControl .plan geofences) -> a map file",
        description="Read GeoJSON FeatureCollections whose features say their layer in a `kind` "
        "property (sensor [id, required_data], obstacle or building, no_fly_zone, start, end, "
        "area, circle) and QGroundControl .plan files (exclusion fences become no-fly zones and "
        "circular obstacles, the inclusion fence the area, the planned home the start and end). "
        "Coordinates are WGS84 (RFC 7946). Origin: --origin, else the frame of an `area` "
        "feature written by `map to-geojson`, else the south-west corner of the data's bounds "
        "grown by --margin (its altitude: a .plan's planned home). Several inclusion fences: "
        "their intersection (a vehicle must stay inside every one on ArduPilot and current "
        "PX4). The map settings (name, uav, radio, objective, safety, fleet, witness) an "
        "exported `area` feature carries are restored; absent, the defaults apply. Polygons may "
        "be non-convex, with holes; rings are cleaned (closing, duplicate and collinear "
        "vertices within 5 mm) and self-intersections refused naming the feature. Obstacles "
        "partly outside the area are clipped to it.",
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
                    "data's bounds grown by --margin); ALT defaults to a .plan's planned "
                    "home altitude, else 0")
    fg.add_argument("--margin", default="100", metavar="M",
                    help="metres of area around the data when the area is not given (default 100)")
    fg.add_argument("--name", help="map name (default: the name an exported `area` feature "
                    "carries, else the first input's file name)")
    fg.add_argument("-o", "--output", required=True, help="map file to write (JSON)")
    fg.add_argument("--mkdir", action="store_true", help="create -o's folder if missing")
    tg = msub.add_parser(
        "to-geojson",
        help="a map file -> GeoJSON (WGS84), readable by GIS tools and by from-geojson",
        description="Write MAP as a GeoJSON FeatureCollection: area, obstacles (holes kept), "
        "no-fly zones, circles, sensors, start and end, each with a `kind` property. The area "
        "feature's properties carry the map's frame and its settings (name, uav, radio, "
        "objective, safety, fleet, witness), so `map from-geojson` gives the same map back.",
    )
    tg.add_argument("map", help="map file (JSON)")
    tg.add_argument("-o", "--output", required=True, help="GeoJSON file to write")
    tg.add_argument("--mkdir", action="store_true", help="create -o's folder if missing")
    cg = msub.add_parser(
        "campus",
        help="write a generated campus of non-convex footprints (a benchmark at real scale)",
        description="A seeded campus: N footprints (L, U, T shapes, blocks with a courtyard) on "
        "a grid of lots over a 5 km area, sensors in empty lots, start and end in the corners. "
        "The benchmarks use campus-500 at seed 0. The map is placed at --origin (default: the "
        "generated maps' fixed origin) so `plan` can write its missions in WGS84. The map is "
        "diagnosed as `check` does; one no plan can meet (too many sensors in one another's "
        "radio range for C3, the paper's simultaneous uplink) is not written: exit status 1 "
        "naming the first reason and what to change. Same seed, same bytes.",
    )
    cg.add_argument("--footprints", type=int, default=500, metavar="N", help="default 500")
    cg.add_argument("--sensors", type=int, default=15, metavar="N", help="default 15")
    cg.add_argument("--seed", type=int, default=0, help="default 0")
    cg.add_argument("--origin", metavar="LAT,LON[,ALT]",
                    help="WGS84 origin of the local frame (default 23.0493,113.3975,10, the "
                    "origin of every generated map)")
    cg.add_argument("--access", choices=D.ACCESS_MODES, default=D.ACCESS_MODES[0],
                    help="the map's radio.access: simultaneous (default, the paper's C3: the "
                    "sensors a hover point hears share R_lambda at once; the map then has no "
                    "radio entry) or scheduled (time slots, no C3)")
    cg.add_argument("-o", "--output", required=True, help="map file to write (JSON)")
    cg.add_argument("--mkdir", action="store_true", help="create -o's folder if missing")
    return p


def _origin(text: str | None) -> tuple[float, float, float | None] | None:
    """--origin LAT,LON[,ALT] as (lat, lon, alt or None); None when not given.

    Args:
        text: the option's text, or None.

    Returns:
        (lat, lon, alt) with alt None when only LAT,LON are given.

    Raises:
        UsageError: text that is not two or three numbers in range.
    """
    if text is None:
        return None
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        raise UsageError(f"--origin must be LAT,LON[,ALT] in degrees (got {text!r})") from None
    if len(vals) not in (2, 3) or not (-90 <= vals[0] <= 90 and -180 <= vals[1] <= 180):
        raise UsageError(f"--origin must be LAT,LON[,ALT] in degrees (got {text!r})")
    return vals[0], vals[1], vals[2] if len(vals) == 3 else None


def _check_output(args: argparse.Namespace, inputs: list[str]) -> None:
    """The shared output checks (`check_outputs`) for -o, before anything is read: UsageError
    (one line, exit 2) when it is one of the inputs, an existing folder, FIFO or device (never
    replaced), or in a missing folder without --mkdir.

    Args:
        args: the parsed options (output, mkdir).
        inputs: every input path.
    """
    from lamde_mission.commands._common import check_outputs

    check_outputs([("-o/--output", args.output)], mkdir=args.mkdir,
                  inputs=[("input", src) for src in inputs])  # fmt: skip


def _from_geojson(args: argparse.Namespace) -> int:
    import json
    import math
    from pathlib import Path

    from lamde_mission.atomic import write_text_atomic
    from lamde_mission.gis import GisError, build_map, read_layers
    from planner_core.model.mapio import MapError, load_map
    from planner_core.textio import printable

    inputs = [(f, None) for f in args.files]
    inputs += [(f, "obstacle") for f in args.obstacles]
    inputs += [(f, "no_fly_zone") for f in args.no_fly_zones]
    inputs += [(f, "sensor") for f in args.sensors]
    if not inputs:
        raise UsageError("give at least one input FILE (or --obstacles/--no-fly-zones/--sensors)")
    _check_output(args, [f for f, _ in inputs])
    try:
        margin = float(args.margin)
    except ValueError:
        raise UsageError(f"--margin must be a number of metres (got {args.margin!r})") from None
    if not (math.isfinite(margin) and margin >= 0):
        raise UsageError(f"--margin must be a finite number >= 0 (got {args.margin!r})")
    origin = _origin(args.origin)
    try:
        layers = read_layers(inputs)
        doc, notes = build_map(layers, origin=origin, margin=margin, name=args.name,
                               default_name=Path(inputs[0][0]).stem)  # fmt: skip
    except GisError as exc:
        raise UsageError(_at_most(_in_files(exc.problems, [f for f, _ in inputs]))) from None
    try:
        m = load_map(doc)
    except MapError as exc:
        raise UsageError(_at_most([_map_problem(p, layers) for p in exc.problems])) from None
    for note in notes + list(m.notes):
        print(f"note: {note}", file=sys.stderr)
    try:
        path = write_text_atomic(args.output, json.dumps(m.to_dict(), indent=1) + "\n",
                                 mkdir=False)
    except OSError as exc:
        raise UsageError(f"{args.output}: cannot write ({exc.strerror or exc})") from None
    print(f"wrote {printable(path)}: {_contents(m)}; area {m.width:g} m x {m.height:g} m from "
          f"origin ({m.spec.origin.lat:.9f}, {m.spec.origin.lon:.9f})")
    return 0


def _in_files(problems: list[str], files: list[str]) -> list[str]:
    """Each import problem led by the input files it is about: one that names no input (a
    reviewer's "no features: nothing to build a map from") gets them all, the others name
    their feature's file already."""
    from pathlib import Path

    names = [str(f) for f in files] + [Path(f).name for f in files]
    lead = ", ".join(str(f) for f in files)
    return [p if any(p.startswith(f"{n}:") for n in names) else f"{lead}: {p}"
            for p in problems]


def _contents(m: Any) -> str:
    """What a map holds, every obstacle kind counted ("4 sensors, 2 obstacles (1 circle, 1
    rectangle), 1 no-fly zone"): the rectangle of a round trip was missing (only polygons
    were counted as obstacles)."""
    from planner_core.textio import counted

    s = m.summary()
    kinds = [counted(s[k], noun) for k, noun in (("circles", "circle"),
                                                  ("rectangles", "rectangle"),
                                                  ("polygons", "polygon")) if s[k]]  # fmt: skip
    n = s["circles"] + s["rectangles"] + s["polygons"]
    return (f"{counted(s['sensors'], 'sensor')}, {counted(n, 'obstacle')}"
            + (f" ({', '.join(kinds)})" if kinds else "")
            + f", {counted(s['no_fly_zones'], 'no-fly zone')}")


#: problem lines printed at most; the rest are counted ("... and N more")
MOST_PROBLEMS = 20


def _at_most(problems: list[str], most: int = MOST_PROBLEMS) -> str:
    """The first `most` problems, one a line, then "... and N more problems" when there are
    more (200,000 bad features printed 200,000 lines)."""
    lines = problems[:most]
    if len(problems) > most:
        lines.append(f"... and {len(problems) - most:,} more problems")
    return "\n".join(lines)


def _map_problem(problem: str, layers: Any) -> str:
    """A problem of the imported map, naming the feature that carried the field when it is a
    setting restored from an exported area, else 'the imported map'."""
    head = problem.split(":", 1)[0].split(".", 1)[0].split("[", 1)[0]
    if layers.settings is not None and head in layers.settings:
        return f"{layers.settings_where}: {problem}"
    return f"the imported map: {problem}"


def _to_geojson(args: argparse.Namespace) -> int:
    import json

    from lamde_mission.atomic import write_text_atomic
    from lamde_mission.commands._common import load_map_or_fail
    from lamde_mission.gis import map_to_geojson
    from planner_core.textio import counted, printable

    _check_output(args, [args.map])
    m = load_map_or_fail(args.map)
    doc = map_to_geojson(m)
    try:
        path = write_text_atomic(args.output, json.dumps(doc, indent=1, allow_nan=False) + "\n",
                                 mkdir=False)
    except OSError as exc:
        raise UsageError(f"{args.output}: cannot write ({exc.strerror or exc})") from None
    print(f"wrote {printable(path)}: {counted(len(doc['features']), 'feature')}")
    return 0


def _campus(args: argparse.Namespace) -> int:
    from lamde_mission.atomic import write_text_atomic
    from lamde_mission.commands._common import check_outputs, sensor_limit
    from lamde_mission.gis.synthetic import campus_map
    from planner_core import textio
    from planner_core.suite import SUITE_ORIGIN, dumps_map

    if args.seed < 0:
        raise UsageError(f"--seed must be >= 0 (got {args.seed})")
    if args.footprints < 1:
        raise UsageError(f"--footprints must be >= 1 (got {args.footprints})")
    most = sensor_limit()  # what check and plan read (LAMDE_MAX_SENSORS)
    if not 1 <= args.sensors <= most:
        raise UsageError(f"--sensors must be 1..{most} (got {args.sensors}; check and plan read "
                         "at most LAMDE_MAX_SENSORS sensors)")
    check_outputs([("-o/--output", args.output)], mkdir=args.mkdir)
    given = _origin(args.origin)
    origin = (dict(SUITE_ORIGIN) if given is None
              else {"lat": given[0], "lon": given[1],
                    "alt": 0.0 if given[2] is None else given[2]})  # fmt: skip
    try:
        doc = campus_map(args.footprints, seed=args.seed, n_sensors=args.sensors)
    except ValueError as exc:  # both do not fit on the map together
        raise UsageError(f"--footprints/--sensors: {exc}") from None
    # every generated map carries an origin (plan writes WGS84 missions from it): name first
    doc = {"name": doc.pop("name"), "origin": origin, **doc}
    if args.access != D.ACCESS_MODES[0]:
        doc["radio"] = {"access": args.access}
    cannot = _cannot_plan(doc, args)
    if cannot is not None:
        print(f"lamde-mission map campus: {textio.printable(cannot)}", file=sys.stderr)
        return 1
    try:
        path = write_text_atomic(args.output, dumps_map(doc))
    except OSError as exc:
        raise UsageError(f"{args.output}: cannot write ({exc.strerror or exc})") from None
    print(f"wrote {path}: {textio.counted(args.footprints, 'footprint')}, "
          f"{textio.counted(args.sensors, 'sensor')}, origin "
          f"({origin['lat']}, {origin['lon']})")
    return 0


def _cannot_plan(doc: dict[str, Any], args: argparse.Namespace) -> str | None:
    """Why no plan can meet the campus `doc` (the first fatal finding of `check`'s diagnosis,
    `planner_core.model.diagnose`) and what to ask for instead, one line; None when nothing
    rules every plan out. The campus's empty lots hold the sensors, so many sensors in a
    5 km area crowd into one another's radio range and break C3 (campus 1,000 footprints
    with 100 sensors: sensors no C3-respecting hover point receives from).

    Args:
        doc: the map file `map campus` would write.
        args: the parsed options (footprints, sensors, access, output).

    Returns:
        The reason and the advice, or None.
    """
    from planner_core.model.diagnose import diagnose
    from planner_core.model.mapio import load_map
    from planner_core.textio import counted

    d = diagnose(load_map(doc))
    fatal = [f for f in d.findings if f.fatal]
    if not fatal:
        return None
    first = fatal[0]
    if first.kind.startswith("C3_"):
        change = ("ask for fewer --sensors, or pass --access scheduled (C3 is the paper's "
                  "simultaneous uplink; scheduled access lets the sensors in range share the "
                  "bandwidth by time slots)")
    else:
        change = "ask for fewer --sensors or fewer --footprints"
    more = f" (and {counted(len(fatal) - 1, 'more finding')})" if len(fatal) > 1 else ""
    return (f"not writing {args.output}: no plan can meet the campus of "
            f"{counted(args.footprints, 'footprint')} and {counted(args.sensors, 'sensor')}: "
            f"{first.message}{more}; {change}")


def run(args: argparse.Namespace) -> int:
    """`map from-geojson`, `map to-geojson` or `map campus`, by `args.map_command`.

    Args:
        args: the parsed options.

    Returns:
        0 when the output is written.

    Raises:
        UsageError: a bad option, input layer or map, or an output that cannot be written
            (one line per problem, exit 2).
    """
    if args.map_command == "from-geojson":
        return _from_geojson(args)
    if args.map_command == "campus":
        return _campus(args)
    return _to_geojson(args)

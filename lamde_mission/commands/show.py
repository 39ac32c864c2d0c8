"""`lamde-mission show MAP [MISSION] -o OUT`: draw a map, and a mission flown on it, to PNG/SVG."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "show",
        help="draw a map (and a mission on it) to a PNG or SVG file",
        description="Draw MAP: area, obstacles, no-fly zones and sensors; with MISSION (.plan, "
        ".waypoints or a plan result .json) also the path replayed by the simulator, hover "
        "points sized by hover time and sensors coloured by the data collected.",
    )
    p.add_argument("map", help="map file (JSON)")
    from lamde_mission.commands._common import add_origin_option

    add_origin_option(p)
    p.add_argument("mission", nargs="?", help="mission file to draw on the map (optional)")
    p.add_argument("-o", "--output", required=True, help="image file to write (.png or .svg)")
    p.add_argument("--title", help="figure title (default: the map's name and f)")
    p.add_argument("--dpi", type=int, default=150, help="PNG resolution (default 150)")
    return p


def run(args: argparse.Namespace) -> int:
    from lamde_mission.commands._common import load_map_or_fail, with_origin_or_fail
    from lamde_mission.errors import UsageError
    from lamde_mission.plot import IMAGE_SUFFIXES

    out = Path(args.output)
    if out.suffix.lower() not in IMAGE_SUFFIXES:
        raise UsageError(f"{out}: output must be a .png or .svg file")
    if args.dpi <= 0:
        raise UsageError(f"--dpi must be positive, got {args.dpi}")
    m = load_map_or_fail(args.map)
    m = with_origin_or_fail(m, args.origin)
    timeline = None
    if args.mission:
        from lamde_mission.commands.verify import replay_mission_file

        timeline = replay_mission_file(args.mission, m)

    from lamde_mission.plot import plot_mission

    try:
        path = plot_mission(m, out, timeline=timeline, title=args.title, dpi=args.dpi)
    except OSError as exc:
        raise UsageError(f"{out}: cannot write ({exc.strerror or exc})") from None
    print(f"wrote {path}")
    return 0

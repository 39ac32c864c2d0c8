"""`lamde-mission show MAP [MISSION | DIR/] -o OUT`: draw a map, and a mission (or every sortie
of a sortie directory) flown on it, to PNG/SVG."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `lamde-mission show` (options, help).

    Args:
        sub: the subcommands of `lamde_mission.cli.build_parser`.

    Returns:
        The command's parser (`build_parser` sets `run` as its `_run`).
    """
    from lamde_mission.plot import HOVER_LABELS

    p = sub.add_parser(
        "show",
        help="draw a map (and a mission on it) to a PNG or SVG file",
        description="Draw MAP: area, obstacles, no-fly zones and sensors; with MISSION (.plan, "
        ".waypoints or a plan result .json) also the path replayed by the simulator, hover "
        "points sized by hover time and sensors coloured by the data collected; a DO_JUMP loop is "
        "drawn once (each distinct leg, hover point and corner; a hover point visited k times "
        f"labelled 'order · seconds ×k'; past {HOVER_LABELS} hover points the rest unlabelled, "
        "counted in the legend). MISSION may be "
        "a sortie directory (`lamde-mission plan MAP -o DIR/` for a battery or a fleet: "
        "fleet.json and mission-v{k}-s{j}.plan): every sortie replayed and drawn, one colour "
        "per vehicle, one line style per sortie (solid, dashed, dash-dot, dotted and four dash "
        "patterns; from a vehicle's ninth sortie on again, the legend naming the sorties that "
        "share one), depots as "
        "hexagons (every depot of the map; those no sortie uses lighter), battery swaps as "
        "stars, sensors coloured by the data of all sorties together.",
    )
    p.add_argument("map", help="map file (JSON)")
    from lamde_mission.commands._common import add_origin_option

    add_origin_option(p)
    p.add_argument("mission", nargs="?",
                   help="mission file or sortie directory to draw on the map (optional)")
    p.add_argument("-o", "--output", required=True, help="image file to write (.png or .svg)")
    p.add_argument("--title", help="figure title (default: the map's name and f)")
    p.add_argument("--dpi", type=int, default=150,
                   help="PNG resolution, 1 to 600 dots per inch (default 150)")
    p.add_argument("--mkdir", action="store_true",
                   help="create -o's missing folders (otherwise exit 2)")
    return p


def fleet_views(directory: str | Path, m: Any) -> list[Any]:
    """Every sortie of a sortie directory, replayed by the simulator on map `m`.

    Args:
        directory: the sortie directory (fleet.json and its .plan files).
        m: the map.

    Returns:
        `plot.SortieView`s in vehicle, then sortie order.

    Raises:
        UsageError: a bad directory, file or mission (one line naming it): fleet.json as
            `verify MAP DIR/` reads it (`formats.fleet.read_fleet_dir`), a depot the map lacks
            (`sorties.check_sortie_depots`, verify's one check).
    """
    from lamde_mission.commands.verify import replay_mission_file
    from lamde_mission.errors import UsageError
    from lamde_mission.formats.fleet import read_fleet_dir
    from lamde_mission.plot import SortieView
    from lamde_mission.sorties import check_sortie_depots, shared_spots

    try:
        fleet = read_fleet_dir(directory)
        check_sortie_depots(fleet, m)
    except ValueError as exc:  # FleetDirError is one
        raise UsageError(str(exc)) from None
    note = fleet.map_note(m.name, "drawn")
    if note is not None:
        print(f"note: {note}", file=sys.stderr)
    # drawn all the same: the picture is how one finds out
    shared, off = shared_spots(fleet), fleet.disagreement()
    if shared is not None:
        print(f"note: {directory}: {shared}; `verify MAP DIR/` fails it", file=sys.stderr)
    if off is not None:  # it names fleet.json itself
        print(f"note: {off}; `verify MAP DIR/` fails it", file=sys.stderr)
    views = [
        SortieView(v.vehicle, s.sortie, replay_mission_file(str(s.path), m), s.depot_start,
                   s.depot_end)
        for v in fleet.vehicles for s in v.sorties
    ]  # fmt: skip
    if not views:
        raise UsageError(f"{fleet.path}: fleet.json lists no sorties to draw")
    return views


def plot_fleet_dir(
    m: Any, directory: str | Path, out: str | Path, *, title: str | None = None, dpi: int = 150
) -> Path:
    """Replay every sortie of `directory` on `m` and draw them (`plot.fleet_figure`) to `out`.

    Args:
        m: the map.
        directory: the sortie directory.
        out: the .png or .svg file (written atomically).
        title: the figure's title (default: map, vehicles, sorties, swaps).
        dpi: PNG resolution.

    Returns:
        The path written.

    Raises:
        UsageError: a bad directory, mission or output file.
    """
    from lamde_mission.errors import UsageError
    from lamde_mission.plot import plot_fleet

    views = fleet_views(directory, m)
    try:
        return plot_fleet(m, out, views, title=title, dpi=dpi)
    except OSError as exc:
        raise UsageError(f"{out}: cannot write ({exc.strerror or exc})") from None


def run(args: argparse.Namespace) -> int:
    """`show MAP [MISSION | DIR/] -o OUT`: draw the map, with the mission replayed on it (or
    every sortie of a sortie directory), to PNG or SVG.

    Args:
        args: the parsed options.

    Returns:
        0 when the figure is written.

    Raises:
        UsageError: a bad output suffix, --dpi or --title, a bad map or mission, or an output
            that cannot be written: a missing folder without --mkdir (as plan's --plot,
            generate and map), a read-only one (one line per problem, exit 2).
    """
    from lamde_mission.commands._common import (
        check_outputs,
        load_map_or_fail,
        with_origin_or_fail,
    )
    from lamde_mission.errors import UsageError
    from lamde_mission.plot import IMAGE_SUFFIXES, check_dpi
    from planner_core.textio import printable

    out = Path(args.output)
    if out.suffix.lower() not in IMAGE_SUFFIXES:
        raise UsageError(f"{out}: output must be a .png or .svg file")
    try:
        check_dpi(args.dpi, "--dpi")
    except ValueError as e:
        raise UsageError(str(e)) from None
    if args.title is not None:
        bad = next((c for c in args.title if c != "\n" and printable(c) != c), None)
        if bad is not None:  # an SVG cannot hold C0 controls; the others forge or reorder text
            raise UsageError(f"--title: holds the control character {printable(bad)} (a "
                             "figure title is printable text; a newline may split it)")
    if args.mission and Path(args.mission).is_dir():  # before check_outputs makes a folder
        from lamde_mission.sorties import output_in_sortie_dir

        inside = output_in_sortie_dir(args.output, args.mission)
        if inside is not None:
            raise UsageError(f"-o/--output: {inside}")
    check_outputs([("-o/--output", args.output)], mkdir=args.mkdir,
                  inputs=[("map", args.map), ("mission", args.mission)])
    m = load_map_or_fail(args.map)
    if args.mission or args.origin is not None:  # the map alone is drawn in its own metres
        m = with_origin_or_fail(m, args.origin)
    if args.mission and Path(args.mission).is_dir():
        path = plot_fleet_dir(m, args.mission, out, title=args.title, dpi=args.dpi)
        print(f"wrote {printable(path)}")
        return 0
    timeline = None
    if args.mission:
        from lamde_mission.commands.verify import replay_mission_file

        timeline = replay_mission_file(args.mission, m)

    from lamde_mission.plot import plot_mission

    try:
        path = plot_mission(m, out, timeline=timeline, title=args.title, dpi=args.dpi)
    except OSError as exc:
        raise UsageError(f"{out}: cannot write ({exc.strerror or exc})") from None
    print(f"wrote {printable(path)}")
    return 0

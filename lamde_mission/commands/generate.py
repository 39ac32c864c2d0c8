"""`lamde-mission generate`: benchmark maps with a stored witness plan (one map, or the suite)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from lamde_mission.errors import UsageError
from planner_core import defaults as D

_SIZES = (5000, 10000)
_DEFAULT_SEED = D.SUITE_SEED


# the large generator's ranges, spelled here so that `--help` loads no numpy; equal to
# planner_core.suite.large's LAYOUTS, MIN_SIZE, MAX_SIZE, MAX_SENSORS (LAMDE_MAX_SENSORS's
# default), CLUSTER_SIZE (a test holds them equal)
_LAYOUTS = ("uniform", "clustered", "corridor")
_LARGE_SIZES = (5000, 30000)
_LARGE_SENSORS = 1000
_CLUSTER_SIZE = 12


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `lamde-mission generate` (options, help).

    Args:
        sub: the subcommands of `lamde_mission.cli.build_parser`.

    Returns:
        The command's parser (`build_parser` sets `run` as its `_run`).
    """
    lo, hi = _LARGE_SIZES
    p = sub.add_parser(
        "generate",
        help="generate benchmark maps (one map, the 16-task suite, or large deployments)",
        description="Generate maps, each with a stored witness (a known feasible plan, checked "
        "phi == 0) and an origin. The paper's maps (Sec. 3.2): "
        "`generate OUT.json --size 5000|10000 --density 0-7`, or the whole suite: "
        "`generate --suite OUTDIR` (T01..T16). Large deployments: "
        f"`generate OUT.json --layout {'|'.join(_LAYOUTS)} --size {lo}..{hi} "
        "--sensors 1..N [--density 0-7]` (N: LAMDE_MAX_SENSORS, what check and plan read, "
        f"default {_LARGE_SENSORS}; how many sensors fit depends on the "
        "size, layout and density: e.g. 1,000 at 30 km did not fit the uniform layout at "
        "density 7 nor the corridor at density 0 or 7; when they do not fit, generate writes "
        "nothing and exits 1 saying why and what to change): uniform (sensors spread over the "
        "area, "
        "500 m apart at least), clustered (fields of --cluster-size sensors, each served from "
        "points at the field's edge, where C3 holds), corridor (sensors along a pipeline or "
        "road crossing the area, served from beside it); I_max = max(20, min(200, "
        "ceil(sensors / 2))); obstacle counts are the paper's 10 km ones scaled by the area. "
        "`generate --large-suite OUTDIR` writes the large suite L01..L08 (docs/scaling.md). "
        "Every generated map keeps the paper's model: safety clearance 0 m and data margin "
        "0 % (a map file without `safety` gets 10 m and 2 %); set `safety` before a real "
        "flight. Same seed, same bytes.",
    )
    p.add_argument("out", nargs="?", metavar="OUT.json", help="map file to write")
    p.add_argument("--suite", metavar="OUTDIR", help="write T01.json..T16.json into OUTDIR")
    p.add_argument("--large-suite", metavar="OUTDIR",
                   help="write the large suite L01.json..L08.json into OUTDIR")
    p.add_argument("--size", metavar="M", help="map side in metres: 5000 or 10000; with --layout "
                   f"{lo}..{hi}")
    p.add_argument("--density", metavar="D", help="obstacle density 0 (sparse) .. 7 (dense); "
                   "with --layout default 0")
    p.add_argument("--layout", metavar="L",
                   help=f"a large-deployment map: {' | '.join(_LAYOUTS)} (default: the paper's "
                   "generator)")
    p.add_argument("--cluster-size", metavar="K",
                   help=f"sensors per field, --layout clustered only (default {_CLUSTER_SIZE})")
    p.add_argument("--seed", metavar="S", help=f"random seed, >= 0 (default {_DEFAULT_SEED})")
    p.add_argument("--sensors", metavar="N", help="number of sensors (default: by size and "
                   "density; with --layout 0.4 per km^2, within 20..500; at most "
                   f"LAMDE_MAX_SENSORS (default {_LARGE_SENSORS}), fewer where the size, layout "
                   "and density do not fit them)")
    p.add_argument("--name", help="map name stored in the file (default: from the arguments)")
    p.add_argument("--mkdir", action="store_true",
                   help="create the output's folder (OUT.json's, or OUTDIR's parent) if missing")
    return p


def _check_name(name: str | None) -> None:
    """UsageError naming --name when the map format would refuse it (checked up front: the
    generator only meets it when it checks the witness, after the work)."""
    if name is None:
        return
    from planner_core.model.mapio import MapError, load_map

    probe = {"name": name, "area": {"width": 100, "height": 100}, "start": [1, 1],
             "end": [99, 99], "sensors": [{"id": "s", "x": 50, "y": 50}]}  # fmt: skip
    try:
        load_map(probe)
    except MapError as exc:
        why = "; ".join(p.split(": ", 1)[-1] for p in exc.problems if p.startswith("name"))
        raise UsageError(f"--name: {why or exc.problems[0]}") from None


def _int(value: str | None, option: str, default: int | None = None) -> int | None:
    if value is None:
        return default
    try:
        return int(value)
    except ValueError:
        raise UsageError(f"{option} must be an integer (got {value!r})") from None


def run(args: argparse.Namespace) -> int:
    """`generate`: one map (OUT.json with --size and --density, or --layout), the suite
    (--suite) or the large suite (--large-suite); options and outputs checked first.

    Args:
        args: the parsed options.

    Returns:
        0 when the map(s) are written, 1 when the generator cannot make the map asked for.

    Raises:
        UsageError: a bad option, an output that cannot be written (one line, exit 2).
    """
    seed = _int(args.seed, "--seed", _DEFAULT_SEED)
    assert seed is not None
    if seed < 0:
        raise UsageError(f"--seed must be >= 0 (got {seed})")
    _check_name(args.name)
    for option, folder in (("--suite", args.suite), ("--large-suite", args.large_suite)):
        if folder is None:
            continue
        from lamde_mission.commands._common import check_output_folder

        # every output checked before the generation: a file in the way, a missing parent
        # (without --mkdir), a read-only folder or mount
        check_output_folder(option, folder, mkdir=args.mkdir)
        extra = [o for o, v in (("OUT.json", args.out), ("--size", args.size),
                                ("--density", args.density), ("--sensors", args.sensors),
                                ("--layout", args.layout), ("--cluster-size", args.cluster_size),
                                ("--name", args.name),
                                ("--large-suite" if option == "--suite" else "--suite",
                                 args.large_suite if option == "--suite" else args.suite))
                 if v is not None]  # fmt: skip
        if extra:
            what = "16 tasks" if option == "--suite" else "8 large maps"
            raise UsageError(f"{option} writes the fixed {what}; drop {', '.join(extra)}")
        return _run_suite(Path(folder), seed, large=option == "--large-suite")
    if args.out is None:
        raise UsageError("give OUT.json (with --size and --density, or --layout), --suite OUTDIR "
                         "or --large-suite OUTDIR")
    if Path(args.out).is_dir():
        opt = "--large-suite" if args.layout is not None else "--suite"
        raise UsageError(f"{args.out} is a folder; give a file name (or use {opt} {args.out})")
    from lamde_mission.commands._common import check_outputs

    check_outputs([("OUT.json", args.out)], mkdir=args.mkdir)
    if args.layout is not None:
        return _run_large(args, seed)
    if args.cluster_size is not None:
        raise UsageError("--cluster-size is for --layout clustered")
    size = _int(args.size, "--size")
    density = _int(args.density, "--density")
    # a value given is judged first: "--size 7000" alone is a wrong size, not a missing one
    if size is not None and size not in _SIZES:
        raise UsageError(f"--size must be 5000 or 10000 without --layout (got {size})")
    if density is not None and not 0 <= density <= 7:
        raise UsageError(f"--density must be 0..7 (got {density})")
    missing = [need for need, value in (("--size (5000 or 10000)", size),
                                        ("--density (0..7)", density)) if value is None]
    if missing:
        raise UsageError(f"one map without --layout needs {' and '.join(missing)}")
    assert size is not None and density is not None
    sensors = _int(args.sensors, "--sensors")
    from planner_core.suite import max_sensor_count

    if sensors is not None and not 1 <= sensors <= max_sensor_count(size):
        raise UsageError(
            f"--sensors must be 1..{max_sensor_count(size)} on a {size} m map (got {sensors})"
        )
    out = Path(args.out)
    return _run_one(out, size, density, seed, sensors, args.name)


def _run_one(
    out: Path, size: int, density: int, seed: int, sensors: int | None, name: str | None
) -> int:
    from planner_core.suite import GenerationError, dumps_map, generate_map

    t0 = time.perf_counter()
    try:
        data = generate_map(size, density, seed, name=name, n_sensors=sensors)
    except GenerationError as exc:
        print(f"lamde-mission generate: {exc}", file=sys.stderr)
        return 1
    _write_map(out, dumps_map(data))
    print(f"wrote {out}: {_line(data)} ({time.perf_counter() - t0:.1f} s)")
    return 0


def _write_map(out: Path, text: str) -> None:
    """Write OUT.json atomically; an OSError (disk full, the folder changed since it was
    checked) is one UsageError line naming it (nothing half-written)."""
    from lamde_mission.atomic import write_text_atomic
    from planner_core.textio import printable

    try:
        write_text_atomic(out, text)
    except OSError as exc:
        raise UsageError(f"OUT.json: {printable(str(out))}: cannot write "
                         f"({exc.strerror or exc})") from None


def _default_large_sensors(size: int) -> int:
    """0.4 sensors per km^2 (the issue's measured maps), within 20..500."""
    return max(20, min(500, round(0.4 * (size / 1000.0) ** 2)))


def _run_large(args: argparse.Namespace, seed: int) -> int:
    from lamde_mission.commands._common import sensor_limit
    from planner_core.suite import GenerationError, dumps_map
    from planner_core.suite import large as L

    if args.layout not in L.LAYOUTS:
        raise UsageError(f"--layout must be {', '.join(L.LAYOUTS)} (got {args.layout!r})")
    size = _int(args.size, "--size")
    if size is None:
        raise UsageError(f"--layout needs --size ({L.MIN_SIZE}..{L.MAX_SIZE} m)")
    if not L.MIN_SIZE <= size <= L.MAX_SIZE:
        raise UsageError(f"--size must be {L.MIN_SIZE}..{L.MAX_SIZE} with --layout (got {size})")
    density = _int(args.density, "--density", 0)
    assert density is not None
    if not 0 <= density <= 7:
        raise UsageError(f"--density must be 0..7 (got {density})")
    sensors = _int(args.sensors, "--sensors", _default_large_sensors(size))
    assert sensors is not None
    most = sensor_limit()
    if not 1 <= sensors <= most:
        raise UsageError(f"--sensors must be 1..{most} with --layout (got {sensors}; check and "
                         "plan read at most LAMDE_MAX_SENSORS sensors)")
    if args.cluster_size is not None and args.layout != "clustered":
        raise UsageError("--cluster-size is for --layout clustered")
    cluster = _int(args.cluster_size, "--cluster-size", L.CLUSTER_SIZE)
    assert cluster is not None
    if not 1 <= cluster <= 50:
        raise UsageError(f"--cluster-size must be 1..50 (got {cluster})")
    out = Path(args.out)
    t0 = time.perf_counter()
    try:
        data = L.generate_large_map(size, sensors, args.layout, density, seed,
                                    cluster_size=cluster, name=args.name)  # fmt: skip
    except GenerationError as exc:
        print(f"lamde-mission generate: {exc}", file=sys.stderr)
        return 1
    _write_map(out, dumps_map(data))
    print(f"wrote {out}: {_line(data, witness_f=True)} ({time.perf_counter() - t0:.1f} s)")
    return 0


def _note_sensor_limit(maps: list[dict]) -> None:
    """Say on stderr how to read maps with more sensors than LAMDE_MAX_SENSORS allows (the
    large suite's fixed maps; `--layout` asks for at most that many)."""
    from planner_core import textio

    most = max(len(d["sensors"]) for d in maps)
    try:
        cap = textio.limit("sensors")
    except textio.InputError:
        return
    if most > cap:
        print(f"note: {most} sensors is more than LAMDE_MAX_SENSORS ({cap}); check, plan and "
              f"bench read such maps with LAMDE_MAX_SENSORS={most} (or more) set",
              file=sys.stderr)  # fmt: skip


def _run_suite(folder: Path, seed: int, *, large: bool = False) -> int:
    from planner_core.suite import suite_maps
    from planner_core.textio import counted

    option = "--large-suite" if large else "--suite"
    t0 = time.perf_counter()
    if large:
        from planner_core.suite.large import large_suite_maps

        maps = large_suite_maps(seed)
    else:
        maps = suite_maps(seed)
    _write_maps(option, folder, maps, witness_f=large)
    print(f"{counted(len(maps), 'map')} in {time.perf_counter() - t0:.1f} s (seed {seed})",
          flush=True)
    if large:
        _note_sensor_limit(list(maps.values()))
    return 0


def _write_maps(option: str, folder: Path, maps: dict[str, dict], *, witness_f: bool) -> None:
    """Write each map as `folder/NAME.json` (`planner_core.suite.write_maps`), printing a line
    per map; an OSError (disk full, the folder changed since it was checked) is one UsageError
    line naming `option`, the file and how many maps were written."""
    from planner_core.suite import write_maps
    from planner_core.textio import counted, printable

    done: list[Path] = []

    def say(path: Path, data: dict) -> None:
        done.append(path)
        print(f"wrote {path}: {_line(data, witness_f=witness_f)}")

    try:
        write_maps(folder, maps, say)
    except OSError as exc:
        names = list(maps)
        # the map it stopped at, or the folder when that could not be made
        path = folder / f"{names[len(done)]}.json" \
            if folder.is_dir() and len(done) < len(names) else folder
        raise UsageError(f"{option}: {printable(str(path))}: cannot write ({exc.strerror or exc}); "
                         f"{len(done)} of {counted(len(maps), 'map')} written") from None


def _line(d: dict, *, witness_f: bool = False) -> str:
    o = d["obstacles"]
    text = (
        f"'{d['name']}', {d['area']['width']} m, sensors {len(d['sensors'])}, "
        f"circles {len(o['circles'])}, rectangles {len(o['rectangles'])}, "
        f"no-fly zones {len(o['no_fly_zones'])}, "
        f"witness hover points {len(d['witness']['hover_points'])}"
    )
    if witness_f:
        from planner_core.suite.large import witness_score

        f, _ = witness_score(d)
        text += f" (I_max {d['uav']['max_hover_points']}, witness f {f:.2f})"
    return text

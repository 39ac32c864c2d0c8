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


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "generate",
        help="generate benchmark maps (one map, or the 16-task suite)",
        description="Generate maps following the paper's Sec. 3.2, each with a stored witness "
        "(a known feasible plan, checked phi == 0). Either write one map: "
        "`generate OUT.json --size 5000|10000 --density 0-7`, or the whole suite: "
        "`generate --suite OUTDIR` (T01..T08 on 5 km, T09..T16 on 10 km). "
        "Same seed, same bytes.",
    )
    p.add_argument("out", nargs="?", metavar="OUT.json", help="map file to write")
    p.add_argument("--suite", metavar="OUTDIR", help="write T01.json..T16.json into OUTDIR")
    p.add_argument("--size", metavar="M", help="map side in metres: 5000 or 10000")
    p.add_argument("--density", metavar="D", help="obstacle density 0 (sparse) .. 7 (dense)")
    p.add_argument("--seed", metavar="S", help=f"random seed, >= 0 (default {_DEFAULT_SEED})")
    p.add_argument("--sensors", metavar="N", help="number of sensors (default: by size, density)")
    p.add_argument("--name", help="map name stored in the file (default: from the arguments)")
    return p


def _int(value: str | None, option: str, default: int | None = None) -> int | None:
    if value is None:
        return default
    try:
        return int(value)
    except ValueError:
        raise UsageError(f"{option} must be an integer (got {value!r})") from None


def run(args: argparse.Namespace) -> int:
    seed = _int(args.seed, "--seed", _DEFAULT_SEED)
    assert seed is not None
    if seed < 0:
        raise UsageError(f"--seed must be >= 0 (got {seed})")
    if args.suite is not None:
        extra = [o for o, v in (("OUT.json", args.out), ("--size", args.size),
                                ("--density", args.density), ("--sensors", args.sensors),
                                ("--name", args.name)) if v is not None]  # fmt: skip
        if extra:
            raise UsageError(f"--suite writes the fixed 16 tasks; drop {', '.join(extra)}")
        return _run_suite(Path(args.suite), seed)
    if args.out is None:
        raise UsageError("give OUT.json (with --size and --density) or --suite OUTDIR")
    size = _int(args.size, "--size")
    density = _int(args.density, "--density")
    if size is None or density is None:
        raise UsageError("one map needs --size (5000 or 10000) and --density (0..7)")
    if size not in _SIZES:
        raise UsageError(f"--size must be 5000 or 10000 (got {size})")
    if not 0 <= density <= 7:
        raise UsageError(f"--density must be 0..7 (got {density})")
    sensors = _int(args.sensors, "--sensors")
    from planner_core.suite import max_sensor_count

    if sensors is not None and not 1 <= sensors <= max_sensor_count(size):
        raise UsageError(
            f"--sensors must be 1..{max_sensor_count(size)} on a {size} m map (got {sensors})"
        )
    out = Path(args.out)
    if out.is_dir():
        raise UsageError(f"{out} is a folder; give a file name (or use --suite {out})")
    return _run_one(out, size, density, seed, sensors, args.name)


def _run_one(
    out: Path, size: int, density: int, seed: int, sensors: int | None, name: str | None
) -> int:
    from lamde_mission.atomic import write_text_atomic
    from planner_core.suite import GenerationError, dumps_map, generate_map

    t0 = time.perf_counter()
    try:
        data = generate_map(size, density, seed, name=name, n_sensors=sensors)
    except GenerationError as exc:
        print(f"lamde-mission generate: {exc}", file=sys.stderr)
        return 1
    write_text_atomic(out, dumps_map(data))
    print(f"wrote {out}: {_line(data)} ({time.perf_counter() - t0:.1f} s)")
    return 0


def _run_suite(folder: Path, seed: int) -> int:
    import json

    from lamde_mission.atomic import write_text_atomic
    from planner_core.suite import generate_suite

    if folder.exists() and not folder.is_dir():
        raise UsageError(f"--suite {folder}: exists and is not a folder")
    t0 = time.perf_counter()
    paths = generate_suite(folder, seed, write=write_text_atomic)
    for path in paths:
        print(f"wrote {path}: {_line(json.loads(path.read_text()))}")
    print(f"{len(paths)} maps in {time.perf_counter() - t0:.1f} s (seed {seed})")
    return 0


def _line(d: dict) -> str:
    o = d["obstacles"]
    return (
        f"'{d['name']}', {d['area']['width']} m, sensors {len(d['sensors'])}, "
        f"circles {len(o['circles'])}, rectangles {len(o['rectangles'])}, "
        f"no-fly zones {len(o['no_fly_zones'])}, "
        f"witness hover points {len(d['witness']['hover_points'])}"
    )

"""Small helpers shared by command modules."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from lamde_mission.errors import UsageError


def load_map_or_fail(path: str, loaded: Any = None) -> Any:
    """Load and validate a map; turn every problem into a UsageError naming the field.

    The map's notes are printed on stderr ("note: PATH: ...").

    Args:
        path: the map file (JSON).
        loaded: the map already loaded from `path` by the caller (`plan` loads it once to
            choose between one flight and sorties); None: load it here.

    Returns:
        The loaded `planner_core.model.mapio.Map`.

    Raises:
        UsageError: one line per problem, each prefixed with the path (exit 2).
    """
    from planner_core.model.mapio import MapError, load_map
    from planner_core.textio import printable

    shown = printable(path)
    try:
        m = load_map(path) if loaded is None else loaded
    except MapError as exc:
        lines = (printable(p[len(path) + 2:]) if p.startswith(f"{path}: ") else printable(p)
                 for p in exc.problems)  # fmt: skip
        raise UsageError("\n".join(f"{shown}: {ln}" for ln in lines)) from None
    for note in m.notes:
        print(f"note: {shown}: {printable(note)}", file=sys.stderr)
    return m


def sensor_limit() -> int:
    """The most sensors a generated map may have: LAMDE_MAX_SENSORS, what check and plan read
    (`planner_core.textio.limit("sensors")`), so that `generate --layout` and `map campus` write
    only maps those commands accept.

    Returns:
        The limit in force (1,000 unless LAMDE_MAX_SENSORS says otherwise).

    Raises:
        UsageError: LAMDE_MAX_SENSORS is set to anything but a positive integer (one line
            naming it, exit status 2).
    """
    from planner_core import textio

    try:
        return textio.limit("sensors")
    except textio.InputError as exc:
        raise UsageError(str(exc)) from None


def same_file(a: str | Path, b: str | Path) -> bool:
    """Whether paths `a` and `b` name one file: the same resolved path, or the same file
    through a link (`os.path.samefile`, where both exist).

    Args:
        a: a path.
        b: another path.

    Returns:
        True when they name one file; False otherwise, or when one does not exist (and the
        resolved paths differ).
    """
    import os

    if Path(a).resolve() == Path(b).resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet)
        return False


def check_outputs(paths: list[tuple[str, str | None]], *, mkdir: bool = False,
                  inputs: list[tuple[str, str | None]] = ()) -> None:
    """UsageError naming the option and path of the first output that cannot be written, that
    two options share, or that is one of the command's `inputs` (what, path: writing it would
    destroy it), before any work; `mkdir` creates missing folders instead.

    Args:
        paths: (option, path) per output, e.g. ("--plot", "a.png"); a None or empty path
            (option not given) is skipped.
        mkdir: create a missing output folder rather than refuse it.
        inputs: (what, path) per file the command reads, e.g. ("map", "m.json"); a None
            path is skipped.

    Raises:
        UsageError: the first such output, one line naming the option and the path.
    """

    from lamde_mission.errors import UsageError
    from planner_core.atomic import OutputPathError, check_writable
    from planner_core.textio import printable

    seen: dict[str, str] = {}
    for option, path in paths:
        if not path:
            continue
        key = str(Path(path).resolve())
        what = next((w for w, src in inputs if src and same_file(path, src)), None)
        if what is not None:
            raise UsageError(f"{option}: {printable(path)} is the {what} this command "
                             "reads; writing it would replace it (name another file)")
        if key in seen:
            raise UsageError(f"{option}: {printable(path)} is also the {seen[key]} output")
        seen[key] = option
        try:
            check_writable(path, mkdir=mkdir, what=option)
        except OutputPathError as exc:
            raise UsageError(printable(str(exc))) from None


def check_output_folder(option: str, folder: str | Path, *, mkdir: bool = False,
                        whole: bool = False) -> None:
    """UsageError naming `option` and `folder` when that output folder cannot be written
    (`planner_core.atomic.check_folder_writable`: a file in the way, a missing parent without
    `mkdir`, a read-only folder or mount), before any work; `check_outputs` for a folder.

    Args:
        option: the option that names the folder, e.g. "--suite".
        folder: the output folder (it need not exist).
        mkdir: create a missing parent folder rather than refuse it.
        whole: the folder is written beside itself and renamed onto its path (a sortie
            directory), so its parent must take new entries even when it exists.

    Raises:
        UsageError: one line naming the option, the folder and the problem.
    """
    from planner_core.atomic import OutputPathError, check_folder_writable
    from planner_core.textio import printable

    try:
        check_folder_writable(folder, mkdir=mkdir, what=option, whole=whole)
    except OutputPathError as exc:
        raise UsageError(printable(str(exc))) from None


def add_executor_args(p: Any, what: str = "jobs") -> None:
    """--backend / --address: where batch work runs (planner_core.execution).

    Args:
        p: the command's `argparse.ArgumentParser`.
        what: the work's name in the help text ("the {what} run").
    """
    p.add_argument("--backend", choices=("local", "ray"), default="local",
                   help=f"where the {what} run: local = a process pool on this machine "
                   "(default), ray = a Ray cluster (needs the ray extra: "
                   "pip install 'lamde-mission[ray]'); same seeds, same results on either")
    p.add_argument("--address", metavar="ADDR", help="with --backend ray: the cluster, 'auto' "
                   "(the one started on this machine by `ray start --head`) or ray://HOST:PORT "
                   "(Ray Client); default: RAY_ADDRESS if set, else a Ray instance started here "
                   "with --jobs CPUs")


def check_executor_args(args: Any) -> None:
    """UsageError (exit 2) for --jobs above `planner_core.defaults.MAX_JOBS`, --address
    without --backend ray, or --backend ray without Ray installed; does not import Ray, only
    looks for it (`ray_executor.ray_missing`). Each command checks --jobs' lower end itself
    (`train` needs a worker, `bench` and `lam` allow 0).

    Args:
        args: the parsed options (`jobs`, `backend`, `address`; `add_executor_args`).

    Raises:
        UsageError: one line naming the option.
    """
    from planner_core.defaults import MAX_JOBS

    if isinstance(args.jobs, int) and args.jobs > MAX_JOBS:
        raise UsageError(f"--jobs: must be at most {MAX_JOBS} (worker processes, or CPUs of the "
                         f"Ray instance started here), got {args.jobs}")
    if args.address is not None and args.backend != "ray":
        raise UsageError("--address: only with --backend ray")
    if args.backend == "ray":
        from planner_core.execution.ray_executor import ray_missing

        missing = ray_missing()  # the check every path of the executor makes
        if missing is not None:
            raise UsageError(f"--backend ray: {missing}")


def add_origin_option(p: Any) -> None:
    """`--origin LAT,LON[,ALT]`: place a map that has no origin (or move one that has).

    Args:
        p: the command's `argparse.ArgumentParser`.
    """
    p.add_argument("--origin", metavar="LAT,LON[,ALT]",
                   help="WGS84 position of the map's (0, 0) (degrees, degrees, metres AMSL); "
                   "needed when the map has no origin, since a mission is latitude/longitude")


def with_origin_or_fail(m: Any, origin: str | None) -> Any:
    """The map placed by `--origin`, or as it is if it has an origin (no default place is
    ever assumed).

    Args:
        m: the loaded map.
        origin: the `--origin` text, "LAT,LON[,ALT]" (degrees, degrees, metres AMSL), or None.

    Returns:
        The map placed at `origin` (`Map.with_origin`), or `m` itself when `origin` is None.

    Raises:
        UsageError: `origin` is not two or three numbers or is out of range (naming
            --origin), or the map has no origin and none was given (naming `origin`).
    """
    if origin is not None:
        from planner_core.model.mapio import MapError

        try:
            vals = [float(v) for v in origin.split(",")]
            if len(vals) not in (2, 3):
                raise ValueError
        except ValueError:
            raise UsageError(f"--origin: expected LAT,LON[,ALT] in degrees and metres, got "
                             f"{origin!r}") from None  # fmt: skip
        try:
            return m.with_origin(*vals)
        except MapError as exc:
            raise UsageError("\n".join(f"--origin: {p}" for p in exc.problems)) from None
    if m.spec.origin is None:
        raise UsageError(
            "origin: the map has no origin (the latitude/longitude of its (0, 0)), so no "
            'mission can be written or read for it; add "origin": {"lat": ..., "lon": ..., '
            '"alt": ...} to the map or pass --origin LAT,LON[,ALT]'
        )
    return m


def fleet_makespan_words(check: Any) -> str:
    """"; fleet makespan 344.0 s (vehicle 2 lands last, launches included)" for a sortie
    directory's check of two vehicles or more (`lamde_mission.sorties.FleetCheck.
    fleet_makespan`: what the makespan goal minimises, as flown), else "": `plan`'s and
    `verify`'s total line.

    Args:
        check: the `FleetCheck`.

    Returns:
        The words, or "".
    """
    if len(check.vehicles()) < 2:
        return ""
    s, v = check.fleet_makespan
    return f"; fleet makespan {s:.1f} s (vehicle {v} lands last, launches included)"


def clearance_words(clearance: float, fmt: str) -> str:
    """"12.345 m" for the least distance a mission keeps from the obstacles (`Verdicts.
    clearance`, m), "no obstacles" for a map without any (it read "clearance inf m").

    Args:
        clearance: metres, inf without obstacles.
        fmt: the number's format (".3f").

    Returns:
        The words.
    """
    import math

    return f"{clearance:{fmt}} m" if math.isfinite(clearance) else "no obstacles"

"""`lamde-mission lam`: the landscape-aware module (build D_syn's features, select a training set).

``lam build``  probes every BBOB instance of the database once and caches its features
               (resumable: chunks already on disk are skipped).
``lam select`` probes the target tasks (map files), runs the two-stage query and writes the
               training-set JSON that ``planner_core.learning.lam.load_trainset`` reads.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path
from typing import Any

from lamde_mission.commands._common import add_executor_args, check_executor_args
from lamde_mission.errors import UsageError
from planner_core.textio import counted, printable

_FEATURES = ("learned", "ela")
_SELECTIONS = ("global", "random", "local")


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `lamde-mission lam` and its subcommands build and select (options, help).

    Args:
        sub: the subcommands of `lamde_mission.cli.build_parser`.

    Returns:
        The command's parser (`build_parser` sets `run` as its `_run`).
    """
    p = sub.add_parser(
        "lam",
        help="landscape-aware module: build the BBOB feature database, select training problems",
        description="Paper Sec. 4.3. `lam build` computes and caches the landscape features of "
        "the synthetic BBOB database (default 24 functions x dims 20,40,80 x 5 instances; "
        "--full is the paper's 24 x 6 x 100). `lam select --tasks DIR --k 64 -o trainset.json` "
        "picks the K landscape-nearest training problems for the tasks.",
    )
    lsub = p.add_subparsers(dest="lam_command", metavar="SUBCOMMAND", required=True)
    for name, helptext in (
        ("build", "compute and cache D_syn's features (resumable, progress bar)"),
        ("select", "two-stage query for a folder of task maps; write the training set JSON"),
    ):
        q = lsub.add_parser(name, help=helptext, description=helptext)
        _database_options(q)
        if name == "select":
            q.add_argument(
                "--tasks",
                required=True,
                metavar="DIR_OR_MAP",
                help="folder of task map .json files (or one map file)",
            )
            q.add_argument("--k", default="64", metavar="K", help="training problems (default 64)")
            q.add_argument("--seed", default="0", metavar="S", help="task-probe / random seed")
            q.add_argument(
                "--selection",
                default="global",
                choices=_SELECTIONS,
                help="global (LAMDE, default), random (LAMDE-R), local (LAMDE-L)",
            )
            q.add_argument(
                "--features",
                default="learned",
                choices=_FEATURES,
                help="learned (LAMDE, default) or ela (LAMDE-E)",
            )
            q.add_argument("-o", "--out", required=True, metavar="OUT.json",
                           help="the training-set file (written atomically; its folder must "
                           "exist unless --mkdir)")  # fmt: skip
            q.add_argument(
                "--plot",
                metavar="OUT.png",
                help="draw tasks and selection in a 2-D PCA of feature space (.png or .svg)",
            )
            q.add_argument(
                "--mkdir",
                action="store_true",
                help="create the missing folders of -o and --plot",
            )
            q.add_argument(
                "--no-build",
                action="store_true",
                help="fail instead of building missing database chunks",
            )
        else:
            q.add_argument(
                "--features",
                default=",".join(_FEATURES),
                help="extractors to compute, comma-separated (default learned,ela)",
            )
        q.add_argument("--quiet", action="store_true", help="no progress bar")  # fmt: skip
    return p


# planner_core.learning.lam.bbob's MIN_DIMENSION, MAX_DIMENSION, MAX_INSTANCES and .probe's
# N_PROBE, MAX_N_PROBE, as the help shows them: importing those modules here would load numpy
# and scipy to build `--help` (a test holds them equal)
MIN_DIMENSION, MAX_DIMENSION, MAX_INSTANCES, N_PROBE, MAX_N_PROBE = 2, 200, 100, 100, 300


def _database_options(q: argparse.ArgumentParser) -> None:
    q.add_argument(
        "--full",
        action="store_true",
        help="the paper's database: 24 functions x 20..200 dims x 100 instances",
    )
    q.add_argument("--functions", metavar="LIST", help="BBOB ids in 1..24, e.g. 1-24 or 1,3,5")
    q.add_argument("--dims", metavar="LIST", help=f"dimensions in {MIN_DIMENSION}..{MAX_DIMENSION} "
                   "(the paper's database stops at 200), e.g. 20,40,80")  # fmt: skip
    q.add_argument("--instances", metavar="N", help="instances per function and dimension, "
                   f"1..{MAX_INSTANCES} (the paper's database has 100)")  # fmt: skip
    q.add_argument("--n-probe", default=str(N_PROBE), metavar="N",
                   help=f"LHS probe size, 4..{MAX_N_PROBE} (default {N_PROBE}, the paper's); "
                   "the learned encoder's attention holds d x N x N numbers, so memory grows "
                   f"with N squared: ~0.5 GB at d = 200, N = {MAX_N_PROBE}")  # fmt: skip
    q.add_argument("--db-seed", default="0", metavar="S", help="database probe seed (default 0)")
    q.add_argument(
        "--jobs",
        default="0",
        metavar="N",
        help="worker processes for the database build (default 0: this process); with "
        "--backend ray and no --address: the CPUs of the Ray instance started here (0 = all)",
    )
    add_executor_args(q, "database chunks")
    q.add_argument("--cache", metavar="DIR", help="feature cache folder "
                   "(default $LAMDE_CACHE/lam or ~/.cache/lamde-mission/lam)")  # fmt: skip


def _int(value: str, option: str, low: int = 0, high: int | None = None) -> int:
    try:
        v = int(value)
    except ValueError:
        raise UsageError(f"{option} must be an integer (got {printable(value)!r:.60})") from None
    if v < low or (high is not None and v > high):
        want = f">= {low}" if high is None else f"in [{low}, {high}]"
        raise UsageError(f"{option} must be an integer {want} (got {v})")
    return v


_ITEM = re.compile(r"\s*(-?\d+)\s*(?:-\s*(-?\d+)\s*)?")


def _int_list(value: str, option: str, low: int, high: int) -> list[int]:
    """Integers and ranges (``1-24``, ``20,40``), each in [low, high], repeats dropped."""
    out: list[int] = []
    for part in value.split(","):
        if not part.strip():
            continue
        m = _ITEM.fullmatch(part)
        if m is None:
            raise UsageError(f"{option}: expected integers like 1-24 or 20,40, got "
                             f"{printable(value)!r:.80}")  # fmt: skip
        a = int(m.group(1))
        b = a if m.group(2) is None else int(m.group(2))
        for v in (a, b):
            if not low <= v <= high:
                raise UsageError(f"{option}: must be integers in [{low}, {high}], got {v}")
        if b < a:
            raise UsageError(f"{option}: the range {a}-{b} goes down; write {b}-{a}")
        out.extend(v for v in range(a, b + 1) if v not in out)
    if not out:
        raise UsageError(f"{option}: empty list")
    return out


def _database(args: argparse.Namespace, features: list[str]) -> Any:
    """The Database the options name; UsageError naming the option for a bad value (before
    any work; nothing is created)."""
    from planner_core.learning.lam import FULL, Database, DatabaseSpec, make_extractors
    from planner_core.learning.lam.bbob import (
        FUNCTIONS,
        MAX_DIMENSION,
        MAX_INSTANCES,
        MIN_DIMENSION,
    )
    from planner_core.learning.lam.probe import MAX_N_PROBE

    base = FULL if args.full else None
    functions = (_int_list(args.functions, "--functions", FUNCTIONS.start, FUNCTIONS.stop - 1)
                 if args.functions else (base.functions if base else None))  # fmt: skip
    dims = (_int_list(args.dims, "--dims", MIN_DIMENSION, MAX_DIMENSION)
            if args.dims else (base.dimensions if base else None))  # fmt: skip
    instances = (_int(args.instances, "--instances", 1, MAX_INSTANCES)
                 if args.instances else (base.instances if base else None))  # fmt: skip
    n_probe = _int(args.n_probe, "--n-probe", 4, MAX_N_PROBE)
    seed = _int(args.db_seed, "--db-seed")
    try:
        return Database(
            spec=DatabaseSpec.make(functions, dims, instances),
            n_probe=n_probe,
            seed=seed,
            cache_dir=Path(args.cache) if args.cache else None,
            extractors=make_extractors(features),
        )
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def _check_cache(db: Any, args: argparse.Namespace, write: bool) -> None:
    """The cache folder exists (it is created here if not) and, when chunks are to be
    computed (`write`), files can be made in it; else UsageError naming --cache (or the
    default folder and $LAMDE_CACHE), before any work."""
    from planner_core.atomic import OutputPathError, check_writable

    folder = Path(db.cache_dir)
    what = "--cache" if args.cache else "cache folder (--cache, $LAMDE_CACHE)"
    shown = printable(str(folder))
    if folder.exists() and not folder.is_dir():
        raise UsageError(f"{what}: {shown} is a file, not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{what}: cannot create the folder {shown} "
                         f"({exc.strerror or exc})") from None  # fmt: skip
    if write:
        try:
            check_writable(folder / "chunk.npz")
        except OutputPathError:
            raise UsageError(f"{what}: cannot write in the folder {shown}") from None


class _Bar:
    """Progress on stderr: one updating line on a TTY, else a line per tenth."""

    def __init__(self, label: str, quiet: bool):
        self.label, self.quiet = label, quiet
        self.tty = sys.stderr.isatty()
        self.t0 = time.monotonic()
        self.next_tenth = 0.0

    def __call__(self, done: int, total: int) -> None:
        if self.quiet or total == 0:
            return
        frac = done / total
        if not self.tty and frac < self.next_tenth and done < total:
            return
        self.next_tenth = (int(frac * 10) + 1) / 10
        w = 30
        bar = "#" * int(round(frac * w)) + "." * (w - int(round(frac * w)))
        line = f"{self.label} [{bar}] {done}/{total} chunks  {time.monotonic() - self.t0:.0f} s"
        end = "\n" if done == total or not self.tty else ""
        sys.stderr.write(("\r" if self.tty else "") + line + end)
        sys.stderr.flush()


def _build(db: Any, args: argparse.Namespace) -> int:
    from planner_core.execution import make_executor

    jobs = _int(args.jobs, "--jobs")
    executor = make_executor(jobs, args.backend, args.address)
    try:
        return db.build(progress=_Bar("lam build", args.quiet), executor=executor)
    finally:
        executor.close()


def _task_files(path: str) -> list[Path]:
    p = Path(path)
    if p.is_dir():
        files = sorted(p.glob("*.json"))
        if not files:
            raise UsageError(f"--tasks: no .json maps in {printable(str(p))}")
    elif p.is_file():
        files = [p]
    else:
        raise UsageError(f"--tasks: {printable(str(p))} does not exist")
    for f in files:
        _refuse_trainset(f)
    return files


def _refuse_trainset(path: Path) -> None:
    """UsageError in one line when `path` is a training-set file (``lam select``'s output or
    ``train --problems``' input: a top-level "problems" list, no "sensors") given as a map.
    Other problems of the file are left to the map loader, which names them."""
    from planner_core.textio import InputError, read_json

    try:
        data = read_json(path)
    except InputError:
        return
    if (
        isinstance(data, dict)
        and "sensors" not in data
        and (isinstance(data.get("problems"), list) or data.get("format") == "lamde-trainset/1")
    ):
        raise UsageError(f"--tasks: {printable(str(path))}: this is a training-set file "
                         "(`lam select -o` / `train --problems`), not a map; --tasks takes the "
                         "task maps (a folder of map .json files or one map)")  # fmt: skip


def run(args: argparse.Namespace) -> int:
    """`lam build` / `lam select`: every option and output is checked before any work.

    Args:
        args: the parsed options.

    Returns:
        0 on success.

    Raises:
        UsageError: one line naming the option (exit 2).
    """
    args.jobs = _int(args.jobs, "--jobs")  # an integer from here on (check_executor_args' bound)
    check_executor_args(args)
    if args.lam_command == "build":
        names = [s.strip() for s in args.features.split(",") if s.strip()]
        bad = [n for n in names if n not in _FEATURES]
        if bad or not names:
            raise UsageError(f"--features: {bad or 'empty'}; choose from {', '.join(_FEATURES)}")
        db = _database(args, names)
        _check_cache(db, args, write=bool(db.missing()))
        n = _build(db, args)
        print(f"{counted(len(db.spec), 'instance')}, {counted(len(db.chunks()), 'chunk')} ({n} "
              "computed now) "
              f"in {db.cache_dir}")  # fmt: skip
        return 0
    return _select(args)


_PLOT_FORMATS = {".png": "png", ".svg": "svg"}


def _select(args: argparse.Namespace) -> int:
    from lamde_mission.commands._common import check_outputs, load_map_or_fail

    k = _int(args.k, "--k", 1)
    seed = _int(args.seed, "--seed")
    db = _database(args, [args.features])
    if k > len(db.spec):
        raise UsageError(f"--k: {k} is more than the database's {len(db.spec)} instances")
    if args.plot is not None and Path(args.plot).suffix.lower() not in _PLOT_FORMATS:
        raise UsageError(f"--plot: {printable(args.plot)}: must end in .png or .svg")
    files = _task_files(args.tasks)
    check_outputs([("-o", args.out), ("--plot", args.plot)], mkdir=args.mkdir,
                  inputs=[("task map", str(f)) for f in files])  # fmt: skip
    missing = bool(db.missing())
    if missing and args.no_build:
        raise UsageError(f"database features missing in {db.cache_dir}: run `lam build`")
    _check_cache(db, args, write=missing)

    from planner_core.learning.lam import select
    from planner_core.learning.lam.trainset import write_trainset
    from planner_core.model.problem import Problem

    maps = [load_map_or_fail(str(f)) for f in files]
    if missing:
        _build(db, args)
    tasks = [Problem(m) for m in maps]
    names = [m.name or f.stem for m, f in zip(maps, files, strict=True)]
    try:
        doc, arrays = select(db, tasks, names, k=k, seed=seed, selection=args.selection,
                             features=args.features)  # fmt: skip
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    figure = _figure_bytes(args.plot, doc, arrays) if args.plot else None
    write_trainset(args.out, doc)
    if figure is not None:
        from planner_core.atomic import write_bytes_atomic

        write_bytes_atomic(args.plot, figure, mkdir=False)
    fids = sorted({p["objective"]["function"] for p in doc["problems"]})
    print(f"wrote {args.out}: {counted(len(doc['problems']), 'training problem')} "
          f"(objective functions {fids}), rho = {doc['options']['rho']:.3f}")  # fmt: skip
    return 0


def _figure_bytes(path: str, doc: dict[str, Any], arrays: dict[str, Any]) -> bytes:
    """:func:`selection_figure` as PNG or SVG (by `path`'s suffix), rendered in memory
    (`lamde_mission.plot.figure_bytes`: the same selection, the same bytes)."""
    from lamde_mission.plot import figure_bytes

    fmt = _PLOT_FORMATS[Path(path).suffix.lower()]
    return figure_bytes(selection_figure(doc, arrays), fmt, dpi=110)


def selection_figure(doc: dict[str, Any], arrays: dict[str, Any]) -> Any:
    """Tasks and the selected synthetic problems in the first two principal components of the
    database's features; title with the selection's options, legend outside the data.

    Args:
        doc: the training-set document of `planner_core.learning.lam.select` (its
            `options`: tasks, k, selection, features, n_probe, seed).
        arrays: Z (n, k) database features, z_f / z_phi (tasks, k), the selected rows
            `objective` / `constraint` (indices into Z).

    Returns:
        The matplotlib `Figure` (Agg canvas, not saved).

    Raises:
        KeyError: `arrays` or `doc["options"]` lacks one of those entries.
    """
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    Z = arrays["Z"]
    mu = Z.mean(axis=0)
    _, _, vt = np.linalg.svd(Z - mu, full_matrices=False)
    W = vt[:2].T

    def proj(A: Any) -> Any:
        return (np.asarray(A) - mu) @ W

    fig = Figure(figsize=(8.6, 5.6), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    P = proj(Z)
    ax.scatter(P[:, 0], P[:, 1], s=6, c="0.8", label=f"database D_syn ({len(Z):,} instances)")
    so = P[arrays["objective"]]
    sc = P[arrays["constraint"]]
    ax.scatter(so[:, 0], so[:, 1], s=22, c="tab:blue", label="selected objective s_k")
    ax.scatter(sc[:, 0], sc[:, 1], s=22, marker="s", facecolors="none", edgecolors="tab:green",
               label="selected constraint s'_k")  # fmt: skip
    tf, tp = proj(arrays["z_f"]), proj(arrays["z_phi"])
    ax.scatter(tf[:, 0], tf[:, 1], s=90, marker="*", c="tab:red", label="task objective z_f")
    ax.scatter(tp[:, 0], tp[:, 1], s=60, marker="x", c="tab:orange",
               label="task constraint z_phi")  # fmt: skip
    o = doc["options"]
    tasks = list(o.get("tasks", []))
    shown = ", ".join(tasks[:6]) + (", ..." if len(tasks) > 6 else "")
    fig.suptitle(f"Landscape-aware selection (paper Sec. 4.3): K = "
                 f"{counted(o['k'], 'training problem')} for {counted(len(tasks), 'task')} "
                 f"({shown})\nselection {o['selection']}, {o['features']} features, "
                 f"N_probe {o['n_probe']}, seed {o['seed']}",
                 fontsize=10)  # fmt: skip
    ax.set_xlabel("principal component 1 of the landscape features (unitless)")
    ax.set_ylabel("principal component 2 (unitless)")
    ax.grid(True, alpha=0.3)
    fig.legend(*ax.get_legend_handles_labels(), loc="outside right center", fontsize=8)
    return fig

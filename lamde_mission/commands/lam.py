"""`lamde-mission lam`: the landscape-aware module (build D_syn's features, select a training set).

``lam build``  probes every BBOB instance of the database once and caches its features
               (resumable: chunks already on disk are skipped).
``lam select`` probes the target tasks (map files), runs the two-stage query and writes the
               training-set JSON that ``planner_core.learning.lam.load_trainset`` reads.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from lamde_mission.commands._common import add_executor_args, check_executor_args
from lamde_mission.errors import UsageError

_FEATURES = ("learned", "ela")
_SELECTIONS = ("global", "random", "local")


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
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
            q.add_argument("-o", "--out", required=True, metavar="OUT.json")
            q.add_argument(
                "--plot",
                metavar="OUT.png",
                help="draw tasks and selection in a 2-D PCA of feature space",
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


def _database_options(q: argparse.ArgumentParser) -> None:
    q.add_argument(
        "--full",
        action="store_true",
        help="the paper's database: 24 functions x 20..200 dims x 100 instances",
    )
    q.add_argument("--functions", metavar="LIST", help="BBOB ids, e.g. 1-24 or 1,3,5")
    q.add_argument("--dims", metavar="LIST", help="dimensions, e.g. 20,40,80")
    q.add_argument("--instances", metavar="N", help="instances per function and dimension")
    q.add_argument("--n-probe", default="100", metavar="N", help="LHS probe size (default 100)")
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


def _int(value: str, option: str, low: int = 0) -> int:
    try:
        v = int(value)
    except ValueError:
        raise UsageError(f"{option} must be an integer (got {value!r})") from None
    if v < low:
        raise UsageError(f"{option} must be >= {low} (got {v})")
    return v


def _int_list(value: str, option: str) -> list[int]:
    out: list[int] = []
    try:
        for part in value.split(","):
            if "-" in part.strip()[1:]:
                a, b = part.split("-", 1)
                out.extend(range(int(a), int(b) + 1))
            elif part.strip():
                out.append(int(part))
    except ValueError:
        raise UsageError(f"{option}: expected integers like 1-24 or 20,40, got {value!r}") from None
    if not out:
        raise UsageError(f"{option}: empty list")
    return out


def _database(args: argparse.Namespace, features: list[str]) -> Any:
    from planner_core.learning.lam import FULL, Database, DatabaseSpec, make_extractors

    base = FULL if args.full else None
    try:
        spec = DatabaseSpec.make(
            _int_list(args.functions, "--functions") if args.functions else
            (base.functions if base else None),
            _int_list(args.dims, "--dims") if args.dims else (base.dimensions if base else None),
            _int(args.instances, "--instances", 1) if args.instances else
            (base.instances if base else None),
        )  # fmt: skip
        return Database(
            spec=spec,
            n_probe=_int(args.n_probe, "--n-probe", 4),
            seed=_int(args.db_seed, "--db-seed"),
            cache_dir=Path(args.cache) if args.cache else None,
            extractors=make_extractors(features),
        )
    except ValueError as exc:
        raise UsageError(str(exc)) from None


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
            raise UsageError(f"--tasks: no .json maps in {p}")
        return files
    if p.is_file():
        return [p]
    raise UsageError(f"--tasks: {p} does not exist")


def run(args: argparse.Namespace) -> int:
    _int(args.jobs, "--jobs")
    check_executor_args(args)
    if args.lam_command == "build":
        names = [s.strip() for s in args.features.split(",") if s.strip()]
        bad = [n for n in names if n not in _FEATURES]
        if bad or not names:
            raise UsageError(f"--features: {bad or 'empty'}; choose from {', '.join(_FEATURES)}")
        db = _database(args, names)
        n = _build(db, args)
        print(f"{len(db.spec)} instances, {len(db.chunks())} chunks ({n} computed now) "
              f"in {db.cache_dir}")  # fmt: skip
        return 0
    return _select(args)


def _select(args: argparse.Namespace) -> int:
    from lamde_mission.commands._common import load_map_or_fail

    k = _int(args.k, "--k", 1)
    seed = _int(args.seed, "--seed")
    files = _task_files(args.tasks)
    db = _database(args, [args.features])
    if k > len(db.spec):
        raise UsageError(f"--k: {k} is more than the database's {len(db.spec)} instances")
    if args.out and Path(args.out).is_dir():
        raise UsageError(f"-o: {args.out} is a folder")
    if db.missing():
        if args.no_build:
            raise UsageError(f"database features missing in {db.cache_dir}: run `lam build`")
        _build(db, args)

    from planner_core.learning.lam import select
    from planner_core.learning.lam.trainset import write_trainset
    from planner_core.model.problem import Problem

    maps = [load_map_or_fail(str(f)) for f in files]
    tasks = [Problem(m) for m in maps]
    names = [m.name or f.stem for m, f in zip(maps, files, strict=True)]
    try:
        doc, arrays = select(db, tasks, names, k=k, seed=seed, selection=args.selection,
                             features=args.features)  # fmt: skip
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    write_trainset(args.out, doc)
    if args.plot:
        _plot(args.plot, doc, arrays)
    fids = sorted({p["objective"]["function"] for p in doc["problems"]})
    print(f"wrote {args.out}: {len(doc['problems'])} training problems "
          f"(objective functions {fids}), rho = {doc['options']['rho']:.3f}")  # fmt: skip
    return 0


def _plot(path: str, doc: dict[str, Any], arrays: dict[str, Any]) -> None:
    """Write :func:`selection_figure` as PNG to `path` (atomically)."""
    import io

    from planner_core.atomic import write_bytes_atomic

    buf = io.BytesIO()
    selection_figure(doc, arrays).savefig(buf, format="png", dpi=110)
    write_bytes_atomic(path, buf.getvalue())


def selection_figure(doc: dict[str, Any], arrays: dict[str, Any]) -> Any:
    """Tasks and the selected synthetic problems in the first two principal components of the
    database's features (`arrays`: Z (n, k) database features, z_f / z_phi (tasks, k), the
    selected rows `objective` / `constraint`); title with the selection's options, legend
    outside the data."""
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
    fig.suptitle(f"Landscape-aware selection (paper Sec. 4.3): K = {o['k']} training problems "
                 f"for {len(tasks)} task(s) ({shown})\nselection {o['selection']}, "
                 f"{o['features']} features, N_probe {o['n_probe']}, seed {o['seed']}",
                 fontsize=10)  # fmt: skip
    ax.set_xlabel("principal component 1 of the landscape features (unitless)")
    ax.set_ylabel("principal component 2 (unitless)")
    ax.grid(True, alpha=0.3)
    fig.legend(*ax.get_legend_handles_labels(), loc="outside right center", fontsize=8)
    return fig

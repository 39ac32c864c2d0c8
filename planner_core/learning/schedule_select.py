"""LAMDE-S, first form (issue 34, part 1): a contextual selector of the improving stage's
schedule, learned from a grid of runs.

When the `improve` stage starts, the selector reads nine features of the map and of the run so
far (`FEATURES`: sensors, obstacles, area, I_max; the incumbent against the best constructive
plan, its hover points over I_max, the pool's distinct feasible structures and the next one's
gap, the share of the budget left), finds the `k` nearest cases of its training table
(features standardised on the table, log1p of the counts, Euclidean distance) and follows the
schedule template (`planner_core.pipeline.schedule.SCHEDULES` or "default") whose mean gap to
the per-case best template was least on those neighbours; ties go to the template that was
best on the whole table (the best static schedule). This is the contextual selector the issue
asks for before reinforcement learning ("map and early-run features -> one of a handful of
schedule templates"; algorithm selection by k nearest neighbours as in the per-instance
algorithm selection literature, Kerschke, Hoos, Neumann & Trautmann, Evol. Comput. 27(1),
2019). No torch: the table is a numpy array shipped with the package
(`checkpoints/lamde-s/table.npz` and its `manifest.json`: the records it was fitted on, the
commit, the command).

Fitting (`fit`, `python -m planner_core.learning.schedule_select fit RECORDS ... -o DIR`) takes
the JSON lines of `benchmarks/bench_schedule.py` (one line per case and template, with the
case's features) and keeps the cases where every template ran and was feasible; `k` is chosen
by leave-one-map-out on the training records themselves (`cross_validate`).

Cost: the features are one `Problem.breakdown` per feasible pool plan (the pool holds the
constructive, seeder and descended plans: ~100 at the default; O(I x J) each) plus O(n x 9)
for the neighbours over a table of n cases, once per plan; the schedule it picks costs what
that template's actions cost (`planner_core.pipeline.schedule`).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from planner_core.pipeline.schedule import _points, pool_structures

__all__ = [
    "DEFAULT_TABLE",
    "FEATURES",
    "SelectorScheduler",
    "SelectorTable",
    "cases_from_records",
    "cross_validate",
    "fit",
    "run_features",
]

#: the selector's inputs, in the table's column order
FEATURES: tuple[str, ...] = ("sensors", "obstacles", "area_km2", "imax", "f_vs_constructive",
                             "points_over_imax", "structures", "next_structure_gap",
                             "improve_share")
#: features taken as log1p (counts and sizes spanning decades)
_LOG = frozenset({"sensors", "obstacles", "area_km2", "imax", "structures"})
#: the shipped table
DEFAULT_TABLE = Path(__file__).resolve().parent / "checkpoints" / "lamde-s"
#: k values `fit` tries by leave-one-map-out
K_GRID = (1, 3, 5, 10, 20, 40)


def run_features(problem: Any, x: np.ndarray, f: float, pool: Any, remaining: int,
                 budget: int) -> dict[str, float]:
    """The selector's features of a run whose `improve` stage is about to start.

    Args:
        problem: the run's `Problem`.
        x: the incumbent (d,), problem space; f: its objective (the paper's f, s).
        pool: the run's `Pool` (constructive, seeder, descended plans with f, phi, kinds).
        remaining: evaluations left in the run; budget: the run's budget.

    Returns:
        `FEATURES` -> value: sensors, obstacles (circles, rectangles, no-fly zones, polygons),
        area (km^2), I_max; the incumbent's f against the best feasible constructive plan
        (per cent, 0 without one); its hover points / I_max; the number of distinct hover-point
        counts among the pool's feasible plans and the gap of the best plan of another count
        (per cent, 0 without one); remaining / budget.
    """
    kinds = np.array(pool.kinds) if len(pool) else np.zeros(0, dtype=str)
    feasible = pool.phi == 0 if len(pool) else np.zeros(0, dtype=bool)
    cons = pool.f[feasible & (kinds == "constructive")] if len(pool) else np.zeros(0)
    by_n = pool_structures(problem, pool)
    n_inc = _points(problem, x)
    others = sorted(v for n, v in by_n.items() if n != n_inc)
    return {
        "sensors": float(len(problem.map.spec.sensors)),
        "obstacles": float(problem.map.spec.obstacles.count),
        "area_km2": problem.map.width * problem.map.height / 1e6,
        "imax": float(problem.n_points),
        "f_vs_constructive": (float(f) / float(cons.min()) - 1) * 100 if len(cons) else 0.0,
        "points_over_imax": n_inc / max(problem.n_points, 1),
        "structures": float(len(by_n)),
        "next_structure_gap": (others[0] / float(f) - 1) * 100 if others else 0.0,
        "improve_share": remaining / budget,
    }


def _transform(F: np.ndarray) -> np.ndarray:
    """log1p of the count columns (`_LOG`), the rest as they are; F (n, 9)."""
    F = np.asarray(F, dtype=float)
    logs = np.array([n in _LOG for n in FEATURES])
    return np.where(logs, np.log1p(np.abs(F)), F)


@dataclass(frozen=True)
class SelectorTable:
    """The training cases of a selector.

    Attributes:
        features: (n, 9) raw features (`FEATURES` order) of the n training cases.
        gaps: (n, T) per cent gap of each template to the case's best template.
        templates: the T template names, the best static one (least mean gap) first.
        maps: (n,) the map of each case (for leave-one-map-out).
        k: neighbours consulted.
        meta: what it was fitted on (records, commit, command, cross-validation).
    """

    features: np.ndarray
    gaps: np.ndarray
    templates: tuple[str, ...]
    maps: tuple[str, ...]
    k: int
    meta: dict[str, Any]

    def predict(self, features: dict[str, float] | Sequence[float],
                rows: np.ndarray | None = None, k: int | None = None) -> str:
        """The template for one case.

        Args:
            features: `FEATURES` -> value, or the 9 values in that order.
            rows: the training rows to use (boolean (n,) or indices; None: all), for
                cross-validation.
            k: neighbours (None: the table's).

        Returns:
            A template name: the least mean gap over the k nearest rows; ties to the first in
            `templates` (the best static one).
        """
        v = np.array([features[n] for n in FEATURES] if isinstance(features, dict)
                     else features, dtype=float)
        idx = np.arange(len(self.gaps)) if rows is None else np.flatnonzero(
            rows) if np.asarray(rows).dtype == bool else np.asarray(rows)
        Z = _transform(self.features[idx])
        mu, sd = Z.mean(0), Z.std(0) + 1e-9
        z = (_transform(v[None])[0] - mu) / sd
        d = (((Z - mu) / sd - z) ** 2).sum(1)
        near = np.argsort(d, kind="stable")[: (k or self.k)]
        return self.templates[int(np.argmin(self.gaps[idx][near].mean(0)))]

    def save(self, directory: str | Path) -> Path:
        """Write `table.npz` and `manifest.json` into `directory` (created).

        Returns:
            The directory.
        """
        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(out / "table.npz", features=self.features, gaps=self.gaps,
                            templates=np.array(self.templates), maps=np.array(self.maps))
        meta = dict(self.meta, k=self.k, features=list(FEATURES), templates=list(self.templates),
                    cases=len(self.gaps), maps=len(set(self.maps)))
        (out / "manifest.json").write_text(json.dumps(meta, indent=1, sort_keys=True) + "\n")
        return out

    @classmethod
    def load(cls, directory: str | Path = DEFAULT_TABLE) -> SelectorTable:
        """Read a table written by `save`.

        Raises:
            ValueError: one line naming the directory when it holds no table.
        """
        d = Path(directory)
        try:
            with np.load(d / "table.npz") as z:
                features, gaps = z["features"], z["gaps"]
                templates, maps = tuple(str(t) for t in z["templates"]), tuple(
                    str(m) for m in z["maps"])
            meta = json.loads((d / "manifest.json").read_text())
        except (OSError, KeyError, ValueError) as exc:
            raise ValueError(f"scheduler: no selector table in {d} ({exc})") from None
        if list(meta.get("features", [])) != list(FEATURES):
            raise ValueError(f"scheduler: {d} was fitted on other features "
                             f"{meta.get('features')}")
        return cls(features, gaps, templates, maps, int(meta["k"]), meta)


def cases_from_records(records: Iterable[dict[str, Any]]) -> tuple[
        list[tuple[str, int]], np.ndarray, np.ndarray, list[str]]:
    """The complete cases of grid records (`benchmarks/bench_schedule.py` lines).

    Returns:
        (keys, F, G, templates): the templates every case ran (sorted; records of others are
        left out); (map, seed) of each case where all of them were feasible; F (n, 9)
        features; G (n, T) per cent gaps to the case's best of those templates.
    """
    by_case: dict[tuple[str, int], dict[str, dict[str, Any]]] = {}
    for r in records:
        by_case.setdefault((r["map"], r["seed"]), {})[r["template"]] = r
    common = set.intersection(*(set(c) for c in by_case.values())) if by_case else set()
    templates = sorted(common)
    keys, F, G = [], [], []
    for key, c in by_case.items():
        c = {t: c[t] for t in templates}
        if not c or any(r["phi"] != 0 for r in c.values()):
            continue
        feats = c[templates[0]].get("features") or {}
        if set(FEATURES) - set(feats):
            continue
        best = min(r["f"] for r in c.values())
        keys.append(key)
        F.append([feats[n] for n in FEATURES])
        G.append([(c[t]["f"] - best) / best * 100 for t in templates])
    return keys, np.array(F, dtype=float).reshape(-1, len(FEATURES)), np.array(
        G, dtype=float).reshape(-1, len(templates)), templates


def _order_best_first(G: np.ndarray, templates: list[str]) -> tuple[np.ndarray, list[str]]:
    order = np.argsort(G.mean(0), kind="stable")
    return G[:, order], [templates[i] for i in order]


def cross_validate(table: SelectorTable, k: int | None = None) -> dict[str, float]:
    """Leave one map out over the table's own cases: each held-out case's template is chosen
    from the other maps' cases, and compared with the best static template of those maps.

    Returns:
        mean gaps (per cent) of the selector, the best static choice and the oracle (0), and
        the cases where the selector is better / worse than the static choice.
    """
    maps = np.array(table.maps)
    chosen, static = [], []
    for m in np.unique(maps):
        train = maps != m
        s = int(np.argmin(table.gaps[train].mean(0)))
        for i in np.flatnonzero(~train):
            pick = table.templates.index(table.predict(table.features[i], rows=train, k=k))
            chosen.append(table.gaps[i, pick])
            static.append(table.gaps[i, s])
    c, s = np.array(chosen), np.array(static)
    return {"selector": float(c.mean()), "static": float(s.mean()), "cases": len(c),
            "better": int((c < s).sum()), "worse": int((c > s).sum())}


def fit(records: Iterable[dict[str, Any]], k: int | None = None,
        meta: dict[str, Any] | None = None) -> SelectorTable:
    """A selector table from grid records.

    Args:
        records: `benchmarks/bench_schedule.py` JSON lines (dicts) with their features.
        k: neighbours; None: the best of `K_GRID` by leave-one-map-out (`cross_validate`).
        meta: provenance stored in the manifest.

    Returns:
        The table (its `meta` holds the cross-validation of every k tried).

    Raises:
        ValueError: no complete, feasible case, or no "default" template among them.
    """
    keys, F, G, templates = cases_from_records(records)
    if not len(keys) or "default" not in templates:
        raise ValueError("records: need cases where every template, 'default' among them, "
                         "ran and was feasible")
    G, templates = _order_best_first(G, templates)
    maps = tuple(m for m, _ in keys)
    table = SelectorTable(F, G, tuple(templates), maps, k or K_GRID[0], dict(meta or {}))
    cv = {kk: cross_validate(table, kk) for kk in ((k,) if k else K_GRID)}
    best_k = min(cv, key=lambda kk: (cv[kk]["selector"], kk))
    info = dict(meta or {}, cross_validation={str(kk): v for kk, v in cv.items()},
                best_static=templates[0])
    return SelectorTable(F, G, tuple(templates), maps, int(best_k), info)


class SelectorScheduler:
    """`--scheduler lamde-s`: at the stage's first decision, the template the selector table
    predicts from `run_features`; then that template's choices (`make_scheduler`). Beyond the
    paper's sizes (`schedule.large_rounds`) the default's, whose rebuilds no template of the
    shipped table has.

    Args:
        table: a `SelectorTable` (None: the shipped one, `DEFAULT_TABLE`).
    """

    name = "lamde-s"

    def __init__(self, table: SelectorTable | None = None) -> None:
        self.table = table if table is not None else _shipped()
        self.template: str | None = None
        self._inner: Any = None
        self._problem: Any = None

    @classmethod
    def from_checkpoint(cls, folder: str) -> SelectorScheduler:
        """The selector of a table folder (`--scheduler lamde-s:DIR`; `SelectorTable.load`)."""
        return cls(SelectorTable.load(folder))

    def reset(self, problem: Any, config: Any) -> None:
        """Forget the last run's choice."""
        self._problem, self.template, self._inner = problem, None, None

    def choose(self, observation: Any) -> str:
        """The chosen template's next action (the template picked at the first call)."""
        if self._inner is None:
            from planner_core.pipeline.schedule import large_rounds, make_scheduler

            st = observation.state
            if large_rounds(st.problem):
                # beyond the paper's sizes the default rebuilds windows, which no template of
                # the table has; there it beats the table's pick (`fresh-heavy`) by 1.1 % of
                # f (docs/scheduler.md, "With the rebuild action"), so it is followed
                self.template = "default"
            else:
                feats = run_features(st.problem, observation.x, observation.f, st.pool,
                                     observation.remaining, observation.budget)
                self.template = self.table.predict(feats)
            self._inner = make_scheduler(self.template)
            self._inner.reset(st.problem, st.config)
        return self._inner.choose(observation)


_SHIPPED: list[SelectorTable] = []


def _shipped() -> SelectorTable:
    if not _SHIPPED:
        _SHIPPED.append(SelectorTable.load(DEFAULT_TABLE))
    return _SHIPPED[0]


def _read(paths: Sequence[str]) -> list[dict[str, Any]]:
    import gzip

    out = []
    for p in paths:
        opener = gzip.open if str(p).endswith(".gz") else open
        with opener(p, "rt") as fh:
            out.extend(json.loads(line) for line in fh if line.strip())
    return out


def main(argv: list[str] | None = None) -> int:
    """`python -m planner_core.learning.schedule_select fit RECORDS ... -o DIR [--k K]`: fit a
    table on grid records, print its leave-one-map-out figures, write it. Returns the exit
    status (2: bad arguments or records)."""
    ap = argparse.ArgumentParser(prog="python -m planner_core.learning.schedule_select",
                                 description="fit the LAMDE-S selector table on "
                                 "bench_schedule.py records")
    sub = ap.add_subparsers(dest="command", required=True)
    f = sub.add_parser("fit")
    f.add_argument("records", nargs="+", help="JSON lines (plain or .gz) of bench_schedule.py")
    f.add_argument("-o", "--output", required=True, help="directory to write the table to")
    f.add_argument("--k", type=int, default=None, help="neighbours (default: chosen by "
                   "leave-one-map-out among 1, 3, 5, 10, 20, 40)")
    args = ap.parse_args(argv)
    if args.k is not None and args.k < 1:
        print(f"schedule_select: --k: must be >= 1, got {args.k}", file=sys.stderr)
        return 2
    try:
        records = _read(args.records)
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, timeout=10).stdout.strip()
        table = fit(records, k=args.k, meta={
            "records": list(args.records),
            "record_commits": sorted({r.get("commit", "") for r in records}),
            "fitted_at": commit, "budget": sorted({r["budget"] for r in records}),
            "command": "python -m planner_core.learning.schedule_select fit "
                       + " ".join(args.records) + f" -o {args.output}"
                       + (f" --k {args.k}" if args.k else "")})
    except (OSError, ValueError, KeyError) as exc:
        print(f"schedule_select: records: {exc}", file=sys.stderr)
        return 2
    table.save(args.output)
    for kk, v in table.meta["cross_validation"].items():
        print(f"k = {kk}: leave-one-map-out mean gap {v['selector']:.4f} % (best static "
              f"{v['static']:.4f} %), better / worse on {v['better']} / {v['worse']} of "
              f"{v['cases']} cases")
    print(f"wrote {args.output}: {len(table.gaps)} cases on {len(set(table.maps))} maps, "
          f"k = {table.k}, templates {', '.join(table.templates)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

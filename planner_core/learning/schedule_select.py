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

The DE's share of the budget (the split, `PlanConfig.de_share`) is chosen too, before the
run's first stage (`SelectorScheduler.configure`), by a second table (`SplitTable`, fitted on
`bench_schedule.py --splits` records): from the map alone (`SPLIT_FEATURES`: sensors,
obstacles, area, I_max and the Clark-Evans ratio of the sensors' layout) the k nearest
training cases give each split's mean gap to the per-case best split and its mean CPU time
against the default split's; the split of least mean gap among those within the CPU cap
(`SplitTable.cap`, 1.5x: issue 34's) is run. Where the DE improves nothing (beyond the paper's
sizes, docs/scheduler.md) a smaller share leaves more of the budget to the improving rounds,
at the cost of their time.

Cost: the features are one `Problem.breakdown` per feasible pool plan (the pool holds the
constructive, seeder and descended plans: ~100 at the default; O(I x J) each) plus O(n x 9)
for the neighbours over a table of n cases, once per plan; the schedule it picks costs what
that template's actions cost (`planner_core.pipeline.schedule`).
"""

from __future__ import annotations

import argparse
import io
import math
import re
import subprocess
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from planner_core.pipeline.schedule import DefaultScheduler, _points, pool_structures
from planner_core.textio import read_bytes, read_json

__all__ = [
    "DEFAULT_TABLE",
    "FEATURES",
    "SPLIT_FEATURES",
    "SelectorScheduler",
    "SelectorTable",
    "SplitTable",
    "capped_best",
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
#: the split table's inputs (`map_features`), in its column order
SPLIT_FEATURES: tuple[str, ...] = ("sensors", "obstacles", "area_km2", "imax", "clark_evans")
#: the split table's CPU cap: a split is chosen only where its mean CPU time over the
#: neighbours is at most this times the default split's (issue 34: 1.5x the default plan)
CPU_CAP = 1.5
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


def map_features(problem: Any) -> dict[str, float]:
    """The split table's features of a problem, before any stage runs (O(J log J)).

    Args:
        problem: the run's `Problem`.

    Returns:
        `SPLIT_FEATURES` -> value: sensors J, obstacles (circles, rectangles, no-fly zones,
        polygons), area (km^2), I_max (hover points; corner slots not counted), and the
        Clark-Evans ratio of the sensors (their mean
        nearest-neighbour distance over 0.5 sqrt(area / J), the mean for points drawn
        uniformly: about 1 for a uniform layout, below for clustered fields, above for a
        regular one; Clark & Evans, Ecology 35(4), 1954; 1 for fewer than 2 sensors).
    """
    from planner_core.model.layout import clark_evans

    xy = np.asarray(problem.sensors, dtype=float).reshape(-1, 2)
    area = problem.map.width * problem.map.height
    ce = clark_evans(xy, area)
    return {
        "sensors": float(len(xy)),
        "obstacles": float(problem.map.spec.obstacles.count),
        "area_km2": area / 1e6,
        "imax": float(problem.hover_limit),  # I_max, corner slots not counted
        "clark_evans": ce,
    }


def _transform(F: np.ndarray, names: Sequence[str] = FEATURES) -> np.ndarray:
    """log1p of the count columns (`_LOG`), the rest as they are; F (n, len(names))."""
    F = np.asarray(F, dtype=float)
    logs = np.array([n in _LOG for n in names])
    return np.where(logs, np.log1p(np.abs(F)), F)


def _query(features: dict[str, float] | Sequence[float], names: Sequence[str],
           rows: np.ndarray | None, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A `predict` call's feature vector (`names` order; a dict or the values in order) and
    its training rows as indices (rows None: all n; boolean (n,) or indices)."""
    v = np.array([features[m] for m in names] if isinstance(features, dict) else features,
                 dtype=float)
    idx = np.arange(n) if rows is None else np.flatnonzero(
        rows) if np.asarray(rows).dtype == bool else np.asarray(rows)
    return v, idx


def _nearest(F: np.ndarray, v: np.ndarray, k: int, names: Sequence[str]) -> np.ndarray:
    """Indices of the k rows of F (n, m) nearest to v (m,): features transformed
    (`_transform`), standardised on F, Euclidean distance, ties by row order."""
    Z = _transform(F, names)
    mu, sd = Z.mean(0), Z.std(0) + 1e-9
    z = (_transform(v[None], names)[0] - mu) / sd
    d = (((Z - mu) / sd - z) ** 2).sum(1)
    return np.argsort(d, kind="stable")[:k]


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
        v, idx = _query(features, FEATURES, rows, len(self.gaps))
        near = _nearest(self.features[idx], v, k or self.k, FEATURES)
        return self.templates[int(np.argmin(self.gaps[idx][near].mean(0)))]

    def save(self, directory: str | Path) -> Path:
        """Write `table.npz` and then `manifest.json` (with the table's sha256,
        `table_sha256`) into `directory` (created), each atomically (`npz_manifest.save`).

        Args:
            directory: the table's folder.

        Returns:
            The directory.

        Raises:
            OSError: the directory cannot be written.
        """
        from planner_core.learning import npz_manifest

        meta = dict(self.meta, k=self.k, features=list(FEATURES), templates=list(self.templates),
                    cases=len(self.gaps), maps=len(set(self.maps)))
        npz_manifest.save(directory, "table.npz",
                          {"features": self.features, "gaps": self.gaps,
                           "templates": np.array(self.templates), "maps": np.array(self.maps)},
                          "manifest.json", meta, compressed=True)
        return Path(directory)

    @classmethod
    def load(cls, directory: str | Path = DEFAULT_TABLE) -> SelectorTable:
        """Read a table written by `save`.

        Args:
            directory: the table's folder (default: the shipped `DEFAULT_TABLE`).

        Returns:
            The `SelectorTable`.

        Raises:
            ValueError: one line naming the directory when it holds no table (files missing or
                unreadable) or its manifest has no integer "k" or one outside 1..cases, or
                naming `table.npz` when it is not the one `manifest.json` describes (its
                `table_sha256`; a manifest without one is not checked).
        """
        import zipfile

        from planner_core.learning.npz_manifest import check_digest

        d = Path(directory)
        try:
            # the shared reader: regular files only (a FIFO never blocks), bounded size and
            # depth (an InputError is a ValueError)
            raw = read_bytes(d / "table.npz")
            with np.load(io.BytesIO(raw), allow_pickle=False) as z:
                features, gaps = z["features"], z["gaps"]
                templates, maps = tuple(str(t) for t in z["templates"]), tuple(
                    str(m) for m in z["maps"])
            meta = read_json(d / "manifest.json")
            if not isinstance(meta, dict):
                raise ValueError("manifest.json: not a JSON object")
        except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile) as exc:
            raise ValueError(f"scheduler: no selector table in {d} ({exc})") from None
        k = meta.get("k")
        if isinstance(k, bool) or not isinstance(k, int):
            raise ValueError(f"scheduler: the selector table in {d}: manifest.json \"k\" must "
                             f"be an integer, got {'nothing' if k is None else repr(k)}")
        stale = check_digest(raw, meta, "table.npz", "manifest.json")
        if stale:
            raise ValueError(f"scheduler: {d}: {stale}")
        if list(meta.get("features", [])) != list(FEATURES):
            raise ValueError(f"scheduler: {d} was fitted on other features "
                             f"{meta.get('features')}")
        if not 1 <= k <= len(gaps):
            raise ValueError(f"scheduler: the selector table in {d}: k must be 1..{len(gaps)}, "
                             f"got {k}")
        return cls(features, gaps, templates, maps, k, meta)


def cases_from_records(records: Iterable[dict[str, Any]]) -> tuple[
        list[tuple[str, int]], np.ndarray, np.ndarray, list[str]]:
    """The complete cases of grid records (`benchmarks/bench_schedule.py` lines).

    Args:
        records: the grid's records (dicts with "map", "seed", "template", "f", "phi" and
            the case's "features").

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

    Args:
        table: the selector table.
        k: neighbours (None: the table's).

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


@dataclass(frozen=True)
class SplitTable:
    """The training cases of the split choice (`bench_schedule.py --splits` records).

    Attributes:
        features: (n, 5) raw `SPLIT_FEATURES` of the n training cases (map, seed).
        gaps: (n, S) per cent gap of each split's plan to the case's best split.
        cpu: (n, S) each split's whole-plan CPU time over the default split's on that case.
        splits: the S DE shares, the default (`planner_core.defaults.DE_SHARE`) first.
        maps: (n,) the map of each case; k: neighbours; cap: the CPU cap (`CPU_CAP`).
        meta: what it was fitted on and its leave-one-map-out figures.
    """

    features: np.ndarray
    gaps: np.ndarray
    cpu: np.ndarray
    splits: tuple[float, ...]
    maps: tuple[str, ...]
    k: int
    cap: float
    meta: dict[str, Any]

    def predict(self, features: dict[str, float] | Sequence[float],
                rows: np.ndarray | None = None, k: int | None = None) -> float:
        """The DE share for one map.

        Args:
            features: `SPLIT_FEATURES` -> value (`map_features`), or the 5 values in order.
            rows: the training rows to use (boolean (n,) or indices; None: all).
            k: neighbours (None: the table's).

        Returns:
            The split of least mean gap over the k nearest rows among those whose mean CPU
            ratio there is at most `cap` (the default split always qualifies; ties to the
            earlier in `splits`, the default first).
        """
        v, idx = _query(features, SPLIT_FEATURES, rows, len(self.gaps))
        near = idx[_nearest(self.features[idx], v, k or self.k, SPLIT_FEATURES)]
        return self.splits[capped_best(self.gaps[near], self.cpu[near], self.cap)]

    def save(self, directory: str | Path) -> Path:
        """Write `split.npz` and then `split.json` (with the table's sha256, `split_sha256`)
        into `directory` (created), each atomically (`npz_manifest.save`).

        Args:
            directory: the table's folder.

        Returns:
            The directory.

        Raises:
            OSError: the directory cannot be written.
        """
        from planner_core.learning import npz_manifest

        meta = dict(self.meta, k=self.k, cap=self.cap, features=list(SPLIT_FEATURES),
                    splits=list(self.splits), cases=len(self.gaps), maps=len(set(self.maps)))
        npz_manifest.save(directory, "split.npz",
                          {"features": self.features, "gaps": self.gaps, "cpu": self.cpu,
                           "splits": np.array(self.splits), "maps": np.array(self.maps)},
                          "split.json", meta, compressed=True)
        return Path(directory)

    @classmethod
    def load(cls, directory: str | Path = DEFAULT_TABLE) -> SplitTable | None:
        """Read a table written by `save`; None when the folder has none (`split.npz`).

        Args:
            directory: the table's folder (default: the shipped `DEFAULT_TABLE`).

        Returns:
            The `SplitTable`, or None.

        Raises:
            ValueError: one line naming the folder when its split table does not load, or
                naming `split.npz` when it is not the one `split.json` describes (its
                `split_sha256`; a manifest without one is not checked).
        """
        import zipfile

        from planner_core.learning.npz_manifest import check_digest

        d = Path(directory)
        if not (d / "split.npz").exists():
            return None
        try:
            raw = read_bytes(d / "split.npz")  # bounded, as the selector table's
            with np.load(io.BytesIO(raw), allow_pickle=False) as z:
                arrays = {n: z[n] for n in ("features", "gaps", "cpu", "splits", "maps")}
            meta = read_json(d / "split.json")
            if not isinstance(meta, dict):
                raise ValueError("split.json: not a JSON object")
            k = meta.get("k")
            if isinstance(k, bool) or not isinstance(k, int):
                raise ValueError(f'"k" must be an integer, got '
                                 f"{'nothing' if k is None else repr(k)}")
            table = cls(arrays["features"].astype(float), arrays["gaps"].astype(float),
                        arrays["cpu"].astype(float),
                        tuple(float(x) for x in arrays["splits"]),
                        tuple(str(m) for m in arrays["maps"]), int(meta["k"]),
                        float(meta["cap"]), meta)
        except (OSError, KeyError, ValueError, TypeError, EOFError,
                zipfile.BadZipFile) as exc:
            raise ValueError(f"scheduler: the split table in {d} does not load ({exc})"
                             ) from None
        stale = check_digest(raw, meta, "split.npz", "split.json")
        if stale:
            raise ValueError(f"scheduler: {d}: {stale}")
        if list(meta.get("features", [])) != list(SPLIT_FEATURES):
            raise ValueError(f"scheduler: the split table in {d} was fitted on other "
                             f"features {meta.get('features')}")
        from planner_core.defaults import DE_SHARE

        n, S = table.gaps.shape
        if table.features.shape != (n, len(SPLIT_FEATURES)) or table.cpu.shape != (n, S) \
                or len(table.splits) != S or len(table.maps) != n or n == 0:
            raise ValueError(f"scheduler: the split table in {d} has inconsistent shapes")
        if not all(np.isfinite(a).all() for a in (table.features, table.gaps, table.cpu)):
            raise ValueError(f"scheduler: the split table in {d} holds non-finite values")
        if not 1 <= table.k <= n:
            raise ValueError(f"scheduler: the split table in {d}: k must be 1..{n}, got "
                             f"{table.k}")
        if not (math.isfinite(table.cap) and table.cap >= 1.0):
            raise ValueError(f"scheduler: the split table in {d}: cap must be a finite number "
                             f">= 1, got {table.cap}")
        if table.splits[0] != DE_SHARE:
            raise ValueError(f"scheduler: the split table in {d}: its first share must be "
                             f"the default {DE_SHARE}, got {table.splits[0]}")
        return table


def capped_best(gaps: np.ndarray, cpu: np.ndarray, cap: float) -> int:
    """The column of least mean gap over the rows of gaps (n, S) among those whose mean CPU
    ratio (cpu (n, S)) is at most `cap`; column 0 (the default split) always qualifies.

    Args:
        gaps: (n, S) per cent gaps to each case's best split.
        cpu: (n, S) CPU time over the default split's.
        cap: the CPU cap.

    Returns:
        The column index (ties to the earlier).
    """
    g = gaps.mean(0)
    over = cpu.mean(0) > cap
    over[0] = False
    return int(np.argmin(np.where(over, np.inf, g)))


def split_cases(records: Iterable[dict[str, Any]]) -> tuple[
        list[tuple[str, int]], np.ndarray, np.ndarray, np.ndarray, list[float]]:
    """The complete cases of split records (`bench_schedule.py --splits`, template
    "default").

    Args:
        records: the records (dicts; those of template "default" with a "de_share" are
            read).

    Returns:
        (keys, F, G, C, splits): the splits at least half the cases ran (the default first,
        then descending); (map, seed) of each case that ran them all, all feasible; F (n, 5) map
        features; G (n, S) per cent gaps to the case's best split; C (n, S) CPU time over
        the default split's.

    Raises:
        ValueError: no case ran the default split; a record without the fields the table
            needs; records of several budgets.
    """
    from planner_core.defaults import DE_SHARE

    by_case: dict[tuple[str, int], dict[float, dict[str, Any]]] = {}
    budgets = set()
    for r in records:
        if r.get("template") == "default" and "de_share" in r:
            missing = [k for k in ("map", "seed", "budget", "f", "phi", "cpu_seconds",
                                   "map_features") if k not in r]
            if missing:
                raise ValueError(f"records: a split record lacks {', '.join(missing)} "
                                 f"(bench_schedule.py --splits writes them)")
            budgets.add(r["budget"])
            by_case.setdefault((r["map"], r["seed"]), {})[float(r["de_share"])] = r
    if len(budgets) > 1:
        raise ValueError(f"records: budgets {sorted(budgets)} mixed; a split table is fitted "
                         f"and scored at one budget")
    # the shares at least half the cases ran (a case cut short by a stopped run, or a stray
    # share, does not shrink the table); cases without all of them are left out
    count: dict[float, int] = {}
    for c in by_case.values():
        for x in c:
            count[x] = count.get(x, 0) + 1
    common = {x for x, n in count.items() if 2 * n >= len(by_case)}
    if DE_SHARE not in common:
        raise ValueError(f"records: need split runs where the cases ran the default split "
                         f"{DE_SHARE} (template 'default', bench_schedule.py --splits)")
    splits = [DE_SHARE, *sorted(common - {DE_SHARE}, reverse=True)]
    keys, F, G, C = [], [], [], []
    for key, c in by_case.items():
        if any(x not in c for x in splits):
            continue
        rows = [c[x] for x in splits]
        feats = rows[0].get("map_features") or {}
        if any(r["phi"] != 0 for r in rows) or set(SPLIT_FEATURES) - set(feats):
            continue
        best = min(r["f"] for r in rows)
        keys.append(key)
        F.append([feats[n] for n in SPLIT_FEATURES])
        G.append([(r["f"] - best) / best * 100 for r in rows])
        C.append([r["cpu_seconds"] / rows[0]["cpu_seconds"] for r in rows])
    S = len(splits)
    return (keys, np.array(F, dtype=float).reshape(-1, len(SPLIT_FEATURES)),
            np.array(G, dtype=float).reshape(-1, S), np.array(C, dtype=float).reshape(-1, S),
            splits)


def map_spec(name: str) -> str:
    """A map's spec: its name without a generator-seed suffix ("L04-s3001" -> "L04",
    "gen-5000-d0-s3400" -> "gen-5000-d0"); maps of one spec from other generator seeds share
    their size, sensor count, layout and density, so a check that holds one out must hold
    them all out.

    Args:
        name: the map's name.

    Returns:
        The name less a final "-s<digits>".
    """
    return re.sub(r"-s\d+$", "", name)


def cross_validate_split(table: SplitTable, k: int | None = None) -> dict[str, float]:
    """Leave one map spec out (`map_spec`: a spec's maps from every generator seed at once)
    over the split table's cases: each held-out case's split chosen from the other specs'
    cases, against the best static split of those cases within the cap (the least mean gap
    among the splits whose mean CPU ratio is at most `cap`).

    Args:
        table: the split table.
        k: neighbours (None: the table's).

    Returns:
        mean gaps (per cent) and mean CPU ratios of the choice and of the static split, and
        the cases where the choice is better / worse.
    """
    maps = np.array([map_spec(m) for m in table.maps])
    chosen, static, c_cpu, s_cpu = [], [], [], []
    for m in np.unique(maps):
        train = maps != m
        s = capped_best(table.gaps[train], table.cpu[train], table.cap)
        for i in np.flatnonzero(~train):
            pick = table.splits.index(table.predict(table.features[i], rows=train, k=k))
            chosen.append(table.gaps[i, pick])
            static.append(table.gaps[i, s])
            c_cpu.append(table.cpu[i, pick])
            s_cpu.append(table.cpu[i, s])
    c, st = np.array(chosen), np.array(static)
    return {"selector": float(c.mean()), "static": float(st.mean()), "cases": len(c),
            "better": int((c < st).sum()), "worse": int((c > st).sum()),
            "selector_cpu": float(np.mean(c_cpu)), "static_cpu": float(np.mean(s_cpu))}


def fit_split(records: Iterable[dict[str, Any]], k: int | None = None, cap: float = CPU_CAP,
              meta: dict[str, Any] | None = None) -> SplitTable:
    """A split table from split records (`split_cases`); k by leave-one-spec-out
    (`cross_validate_split`) when None: the least mean gap.

    Args:
        records: `bench_schedule.py --splits` records (dicts).
        k: neighbours; None: the best of `K_GRID`.
        cap: the CPU cap.
        meta: provenance stored in the manifest.

    Returns:
        The table (its `meta` holds the cross-validation of every k tried).

    Raises:
        ValueError: no complete, feasible case, or the cases of fewer than 2 map specs
            (the fit leaves one out at a time); as `split_cases` raises it.
    """
    keys, F, G, C, splits = split_cases(records)
    if not len(keys):
        raise ValueError("records: no case where every split ran and was feasible")
    maps = tuple(m for m, _ in keys)
    if len({map_spec(m) for m in maps}) < 2:
        raise ValueError("records: the cases of at least 2 map specs are needed (the fit "
                         "leaves one out at a time)")
    table = SplitTable(F, G, C, tuple(splits), maps, k or K_GRID[0], float(cap),
                       dict(meta or {}))
    cv = {kk: cross_validate_split(table, kk) for kk in ((k,) if k else K_GRID)}
    best_k = min(cv, key=lambda kk: (cv[kk]["selector"], kk))
    info = dict(meta or {}, cross_validation={str(kk): v for kk, v in cv.items()})
    return SplitTable(F, G, C, tuple(splits), maps, int(best_k), float(cap), info)


class SelectorScheduler:
    """`--scheduler lamde-s`: at the stage's first decision, the template the selector table
    predicts from `run_features`; then that template's choices (`make_scheduler`). Beyond the
    paper's sizes (`schedule.large_rounds`) the default's, whose rebuilds no template of the
    shipped table has.

    Args:
        table: a `SelectorTable` (None: the shipped one, `DEFAULT_TABLE`).
        split: a `SplitTable` for the DE's share (`configure`); True (default): the shipped
            one, whatever `table` is; None: no split choice. `from_checkpoint` uses the
            folder's `split.npz` when it has one, else none.
    """

    name = "lamde-s"

    def __init__(self, table: SelectorTable | None = None,
                 split: SplitTable | None | bool = True) -> None:
        self.table = table if table is not None else _shipped()
        #: the split table (`configure`); True: the shipped one; None or False: none
        self.split: SplitTable | None = _shipped_split() if split is True else split or None
        self.template: str | None = None
        self._inner: Any = None
        self._problem: Any = None

    @classmethod
    def from_checkpoint(cls, folder: str) -> SelectorScheduler:
        """The selector of a table folder (`--scheduler lamde-s:DIR`; `SelectorTable.load`,
        and its split table when the folder has one, `SplitTable.load`).

        Args:
            folder: the table folder.

        Returns:
            The `SelectorScheduler`.

        Raises:
            ValueError: a table that does not load.
        """
        return cls(SelectorTable.load(folder), SplitTable.load(folder))

    def configure(self, problem: Any, config: Any) -> Any:
        """The run's config with the DE share the split table picks for `problem`
        (`map_features`; `SplitTable.predict`), before any stage runs, but never more than
        the default scheduler gives the map (`DefaultScheduler.configure`: 0 beyond 160
        sensors and 0.2 up to 120 with the large rounds, rules measured after the table was
        fitted on shares 0.3-0.6; a smaller share lowered f on nearly every case of every
        training set, docs/scheduler.md). A config whose `de_share` differs from the default
        (`planner_core.defaults.DE_SHARE`) keeps it; a selector without a split table
        (`SelectorScheduler(split=None)`) gives what the default scheduler gives.

        Args:
            problem: the run's `Problem`.
            config: its `PlanConfig`.

        Returns:
            A `PlanConfig` (`config` itself when nothing changes).
        """
        from planner_core.defaults import DE_SHARE

        if config.de_share != DE_SHARE:
            return config
        default = DefaultScheduler().configure(problem, config)
        if self.split is None:
            return default
        share = min(self.split.predict(map_features(problem)), default.de_share)
        return config if share == config.de_share else config.replace(de_share=share)

    def reset(self, problem: Any, config: Any) -> None:
        """Forget the last run's choice.

        Args:
            problem: the run's `Problem`.
            config: its `PlanConfig` (unused).
        """
        self._problem, self.template, self._inner = problem, None, None

    def choose(self, observation: Any) -> str:
        """The chosen template's next action (the template picked at the first call; beyond
        the paper's sizes, `schedule.large_rounds`, the "default" template).

        Args:
            observation: the improving stage's `schedule.Observation`.

        Returns:
            An action name of `schedule.ACTIONS`.
        """
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
_SHIPPED_SPLIT: list[SplitTable | None] = []


def _shipped() -> SelectorTable:
    if not _SHIPPED:
        _SHIPPED.append(SelectorTable.load(DEFAULT_TABLE))
    return _SHIPPED[0]


def _shipped_split() -> SplitTable | None:
    if not _SHIPPED_SPLIT:
        _SHIPPED_SPLIT.append(SplitTable.load(DEFAULT_TABLE))
    return _SHIPPED_SPLIT[0]


def main(argv: list[str] | None = None) -> int:
    """`python -m planner_core.learning.schedule_select fit RECORDS ... -o DIR [--k K]`: fit a
    table on grid records, print its leave-one-map-out figures, write it; `fit-split ...
    [--cap 1.5]` the same for the DE-share table on `--splits` records (into the same folder:
    the two tables sit side by side).

    Args:
        argv: the arguments (None: ``sys.argv[1:]``).

    Returns:
        The exit status: 0 written, 2 bad arguments or records (one line on stderr). An
        argument argparse refuses exits with status 2 (SystemExit) instead.
    """
    ap = argparse.ArgumentParser(prog="python -m planner_core.learning.schedule_select",
                                 description="fit the LAMDE-S selector table on "
                                 "bench_schedule.py records")
    sub = ap.add_subparsers(dest="command", required=True)
    for name, what in (("fit", "the template table (table.npz)"),
                       ("fit-split", "the DE-share table (split.npz; bench_schedule.py "
                        "--splits records)")):
        f = sub.add_parser(name, help=f"fit {what}", description=f"Fit {what} and write it "
                           "into the output folder, beside the other table.")
        f.add_argument("records", nargs="+",
                       help="JSON lines (plain or .gz) of bench_schedule.py")
        f.add_argument("-o", "--output", required=True,
                       help="directory to write the table to")
        f.add_argument("--k", type=int, default=None, help="neighbours (default: chosen by "
                       "leaving one map out (fit) or one map spec out (fit-split) among "
                       "1, 3, 5, 10, 20, 40)")
    sub.choices["fit-split"].add_argument(
        "--cap", type=float, default=CPU_CAP,
        help=f"CPU cap over the default share's ({CPU_CAP:g})")
    args = ap.parse_args(argv)
    if args.k is not None and args.k < 1:
        print(f"schedule_select: --k: must be >= 1, got {args.k}", file=sys.stderr)
        return 2
    split = args.command == "fit-split"
    if split and not args.cap >= 1.0:
        print(f"schedule_select: --cap: must be >= 1, got {args.cap}", file=sys.stderr)
        return 2
    try:
        from planner_core.textio import read_jsonl

        records = [r for p in args.records for r in read_jsonl(p)]
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, timeout=10).stdout.strip()
        meta = {
            "records": list(args.records),
            "record_commits": sorted({r.get("commit", "") for r in records}),
            "fitted_at": commit, "budget": sorted({r["budget"] for r in records}),
            "command": f"python -m planner_core.learning.schedule_select {args.command} "
                       + " ".join(args.records) + f" -o {args.output}"
                       + (f" --k {args.k}" if args.k else "")
                       + (f" --cap {args.cap:g}" if split and args.cap != CPU_CAP else "")}
        if split:
            stable = fit_split(records, k=args.k, cap=args.cap, meta=meta)
        else:
            table = fit(records, k=args.k, meta=meta)
    except (OSError, ValueError, KeyError) as exc:
        msg = str(exc)
        print(f"schedule_select: {msg if msg.startswith('records:') else 'records: ' + msg}",
              file=sys.stderr)
        return 2
    if split:
        stable.save(args.output)
        for kk, v in stable.meta["cross_validation"].items():
            print(f"k = {kk}: leave-one-spec-out mean gap {v['selector']:.4f} % at "
                  f"{v['selector_cpu']:.2f}x CPU (best static share {v['static']:.4f} % at "
                  f"{v['static_cpu']:.2f}x), better / worse on {v['better']} / {v['worse']} "
                  f"of {v['cases']} cases")
        print(f"wrote {args.output}: {len(stable.gaps)} cases on {len(set(stable.maps))} "
              f"maps, k = {stable.k}, shares {', '.join(f'{x:g}' for x in stable.splits)}")
        return 0
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

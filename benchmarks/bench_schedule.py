"""Issue 34's first baseline: the best static schedule of the improving stage, found by a grid.

For each training map (generated paper-size maps, `planner_core.suite.generate_map`: 5,000 m
and 10,000 m a side alternating, densities 0-7 in turn, map seeds from `--map-seed`; or the
suite's maps with `--suite`) and plan seed, the default pipeline runs once up to its `improve`
stage, then each schedule template (`planner_core.pipeline.schedule`: "default" and the
static `SCHEDULES`) runs the rest from a copy (`PipelineRun.fork`, the same plan as a whole
run with that scheduler, to the bit). Prints per template the mean gap to the per-(map, seed)
best over all templates, how often it is that best, the paired comparison with the default
(mean difference of the gaps, maps better/worse, Wilcoxon signed-rank p, two-sided) and the
improving stage's mean evaluations and seconds; writes one JSON line per run to `-o`.

    python benchmarks/bench_schedule.py [--maps 24] [--seeds 2] [--budget 10000]
        [--templates default kicks-heavy ...] [--map-seed 3400] [--suite [T01 ...]]
        [--large [L01 ...] [--large-seed S]]
        [--splits 0.6 0.4 ...] [--jobs N [--backend local|ray]] [-o runs.jsonl]
        [--summary runs.jsonl ...]
        [--select runs.jsonl ...] [--evaluate TABLE runs.jsonl ...]
        [--evaluate-split TABLE runs.jsonl ...]

Gap = (f - f_best) / f_best in percent, f_best the best feasible f of any template on that map
and seed (an infeasible run is reported and left out of the means). `--summary` prints the
table of earlier records instead of running; `--select` evaluates a contextual selector (map
and early-run features -> a template, k nearest training cases, `select`) leaving one map out
at a time. `--splits` runs each template at several DE shares from a fork before the DE
(records for LAMDE-S's split table, `schedule_select fit-split`), and `--evaluate-split`
scores a split table on held-out ones. Runs in this process, or with `--jobs N` on N
workers of the executor (one (map, seed) case an item; the grid is CPU-bound: run it under
`nice`).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
SUITE = ROOT / "examples" / "maps" / "suite"
LARGE = ROOT / "examples" / "maps" / "large"


def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                              capture_output=True, text=True, timeout=10).stdout.strip()
    except OSError:
        return ""


def suite_maps(tasks: list[str], folder: Path = SUITE) -> list[tuple[str, Any]]:
    """The maps of a suite folder named `tasks` (all of them when empty): (name, path). The
    paper-size suite (T01-T16) by default, the large suite (L01-L08) with `folder=LARGE`."""
    names = tasks or sorted(p.stem for p in folder.glob("*.json"))
    return [(t, folder / f"{t}.json") for t in names]


def large_maps(tasks: list[str], seed: int) -> list[tuple[str, Any]]:
    """The large suite's maps named `tasks` (all 8 when empty) drawn from another generator
    seed: (name, map data), named like ``L04-s3001`` (held-out maps of the same specs as the
    committed suite, `planner_core.suite.large.LARGE_SUITE`)."""
    from planner_core.suite.large import LARGE_SUITE, generate_large_map

    names = tasks or sorted(LARGE_SUITE)
    out = []
    for name in names:
        size, n, layout, density = LARGE_SUITE[name]
        out.append((f"{name}-s{seed}",
                    generate_large_map(size, n, layout, density, seed, name=f"{name}-s{seed}")))
    return out


def case_features(problem: Any, run: Any) -> dict[str, float]:
    """The selector's features (`planner_core.learning.schedule_select.run_features`) of a
    run stopped before `improve`."""
    from planner_core.learning.schedule_select import run_features

    x, f, _ = run.ev.best()
    return run_features(problem, x, f, run.state.pool, run.ev.remaining, run.ev.budget)


def run_case(case: tuple[str, Any, int, int, list[str], list[float] | None, str]
             ) -> list[dict[str, Any]]:
    """One (map, seed) case of the grid: the prefix once, then every template (and share)
    from a copy; its records. `case` = (map name, map source, seed, budget, templates,
    splits, commit). Without `splits` a scheduler that changes the run's config (lamde-s's
    DE share) runs its own whole plan instead, as `plan` would; its CPU seconds are that
    run's. A top-level function, so that `--jobs` workers can run it."""
    from planner_core.learning.schedule_select import map_features
    from planner_core.model.mapio import load_map
    from planner_core.model.problem import Problem
    from planner_core.pipeline import DEFAULT_PIPELINE, PlanConfig
    from planner_core.pipeline.pipeline import PipelineRun, with_scheduler
    from planner_core.pipeline.schedule import DefaultScheduler, configured, make_scheduler

    name, src, seed, budget, templates, splits, commit = case
    problem = Problem(load_map(src).planning_map())
    mfeats = map_features(problem)
    cfg = PlanConfig(seed=seed, budget=budget)
    t0, c0 = time.perf_counter(), time.process_time()
    base = PipelineRun(problem, cfg, pipeline=DEFAULT_PIPELINE, evaluator=None, progress=None)
    base.advance(until="de" if splits else "improve")
    prefix_s, prefix_cpu = time.perf_counter() - t0, time.process_time() - c0
    f_start = float(base.ev.best()[1]) if base.ev.has_best else float("inf")
    feats = case_features(problem, base) if base.ev.has_best and not splits else {}
    records = []
    for tpl in templates:
        # a grid sweeps the default's share (its own rules by sensor count aside); a learned
        # split (lamde-s) runs the share it picks
        sched = make_scheduler(tpl)  # built (a learned one's tables read) once per template
        own = configured(sched, problem, cfg)  # the config the scheduler itself would run
        learned_split = (bool(splits) and hasattr(sched, "configure")
                         and not isinstance(sched, DefaultScheduler))
        if not splits:
            configs = [None]
        elif learned_split:
            configs = [own]
        else:
            configs = [cfg.replace(de_share=x) for x in splits]
        for c in configs:
            whole = not splits and own != base.config
            if whole:
                # a scheduler whose config differs from the default's before the DE (lamde-s's
                # share): the prefix has run the DE already, so its own whole run, as `plan`
                # runs it
                run = PipelineRun(problem, own, pipeline=with_scheduler(DEFAULT_PIPELINE, tpl),
                                  evaluator=None, progress=None)
            else:
                run = base.fork(tpl, config=c)
            t1, c1 = time.perf_counter(), time.process_time()
            run.advance()
            r = run.result()
            imp = [s for s in r.stages if s.name == "improve"]
            records.append({
                "map": name, "seed": seed, "budget": budget, "template": tpl,
                "arm": tpl if not splits or learned_split
                else f"{tpl}@{run.config.de_share:g}",
                "de_share": run.config.de_share,
                "f": r.f, "phi": r.phi, "f_start": f_start,
                "evaluations": r.evaluations,
                "improve_evaluations": imp[0].evaluations if imp else 0,
                "actions": list(r.state.actions),
                "improve_seconds": round(time.perf_counter() - t1, 3),
                "prefix_seconds": round(prefix_s, 3),
                # the whole plan's: the prefix's and the fork's, or a whole run's own
                "cpu_seconds": round((0.0 if whole else prefix_cpu)
                                     + time.process_time() - c1, 3),
                "features": feats, "map_features": mfeats, "commit": commit})
    return records


def run_grid(maps: list[tuple[str, Any]], seeds: list[int], budget: int,
             templates: list[str], out: Any, splits: list[float] | None = None,
             jobs: int = 0, backend: str = "local") -> list[dict[str, Any]]:
    """Every template on every map and seed (the prefix up to `improve` run once each).

    With `splits` (DE shares) the prefix stops before the DE instead, and each template
    runs the rest once per split (`PipelineRun.fork(config=)`: the same plan as a whole run
    with that `de_share`; the default's own shares by sensor count are points of the grid,
    not a rule here), except a learned split (lamde-s with its split table), which
    runs once with the share it picks. Every record holds its `de_share`, the
    whole plan's CPU seconds (`cpu_seconds`: the prefix's and the fork's, process time) and
    the map's features (`map_features`: the split table's inputs).

    `jobs` >= 1 runs the cases on that many workers of the executor (`backend` "local" or
    "ray", `planner_core.execution.make_executor`); the records are the same, written in the
    order the cases end. CPU seconds are each worker's own, so they stay comparable."""
    from planner_core.execution import make_executor

    commit = _commit()
    cases = [(name, src, seed, budget, list(templates), splits, commit)
             for name, src in maps for seed in seeds]
    records: list[dict[str, Any]] = []
    with make_executor(jobs, backend) as ex:
        for recs in ex.map_unordered(run_case, cases):
            records.extend(recs)
            if out is not None:
                out.writelines(json.dumps(r) + "\n" for r in recs)
                out.flush()
            r0 = recs[0]
            print(f"{r0['map']} seed {r0['seed']}: f_start {r0['f_start']:.3f}, " + ", ".join(
                f"{r['arm']} {r['f']:.3f}" for r in recs), file=sys.stderr, flush=True)
    return records


def _read(paths: list[str]) -> list[dict[str, Any]]:
    """The records of bench JSON lines files (plain or .gz), in order (`textio.read_jsonl`)."""
    from planner_core.textio import read_jsonl

    return [r for p in paths for r in read_jsonl(p)]


def _arm(r: dict[str, Any]) -> str:
    """A record's arm: its template, or "template@share" for a split run (`--splits`)."""
    return str(r.get("arm", r["template"]))


def summarise(records: list[dict[str, Any]]) -> str:
    """The markdown table of the module docstring (an arm is a template, or with `--splits`
    a template at a DE share, "default@0.6"; "x CPU" is the mean of each case's whole-plan
    CPU over the reference arm's, where the records hold it; with `--splits` "improve s" is
    the seconds of everything from the DE on, the part a fork runs)."""
    from scipy.stats import wilcoxon

    from planner_core.defaults import DE_SHARE

    by_case: dict[tuple[str, int, int], dict[str, dict[str, Any]]] = {}
    for r in records:
        by_case.setdefault((r["map"], r["seed"], r["budget"]), {})[_arm(r)] = r
    templates = list(dict.fromkeys(_arm(r) for r in records))
    # the paired columns compare with the default (at the default split), or with the first
    # template when the records have no default's runs (`--templates alternate kicks-rebuild`)
    ref = next((t for t in ("default", f"default@{DE_SHARE:g}") if t in templates),
               templates[0])
    cpu: dict[str, list[float]] = {t: [] for t in templates}
    gaps: dict[str, list[float]] = {t: [] for t in templates}
    wins = dict.fromkeys(templates, 0)
    infeasible = dict.fromkeys(templates, 0)
    paired: dict[str, list[float]] = {t: [] for t in templates}
    cases = 0
    for case in by_case.values():
        if set(case) != set(templates):
            continue
        feas = [r["f"] for r in case.values() if r["phi"] == 0]
        if not feas:
            continue
        cases += 1
        best = min(feas)
        for t, r in case.items():
            if r["phi"] > 0:
                infeasible[t] += 1
                continue
            g = (r["f"] - best) / best * 100.0
            gaps[t].append(g)
            wins[t] += r["f"] == best
        if case[ref]["phi"] == 0:
            gd = (case[ref]["f"] - best) / best * 100.0
            for t, r in case.items():
                if r["phi"] == 0:
                    paired[t].append((r["f"] - best) / best * 100.0 - gd)
        if case[ref].get("cpu_seconds"):
            for t, r in case.items():
                if "cpu_seconds" in r:
                    cpu[t].append(r["cpu_seconds"] / case[ref]["cpu_seconds"])
    ev = {t: statistics.fmean(r["improve_evaluations"] for r in records if _arm(r) == t)
          for t in templates}
    sec = {t: statistics.fmean(r["improve_seconds"] for r in records if _arm(r) == t)
           for t in templates}
    lines = [f"{cases} (map, seed) cases, budget {sorted({k[2] for k in by_case})}", "",
             f"| template | mean gap % | best in | vs {ref}: mean diff % | better / worse "
             "| Wilcoxon p | improve evals | improve s | x CPU | infeasible |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    order = sorted(templates, key=lambda t: statistics.fmean(gaps[t]) if gaps[t] else 1e9)
    for t in order:
        d = paired[t]
        better, worse = sum(x < 0 for x in d), sum(x > 0 for x in d)
        p = "-"
        if t != ref and any(x != 0 for x in d):
            p = f"{wilcoxon(d).pvalue:.3g}"
        mean = statistics.fmean(gaps[t]) if gaps[t] else float("nan")
        diff = statistics.fmean(d) if d else float("nan")
        x_cpu = f"{statistics.fmean(cpu[t]):.2f}" if cpu[t] else "-"
        lines.append(f"| {t} | {mean:.4f} | {wins[t]} | {diff:+.4f} | {better} / {worse} | "
                     f"{p} | {ev[t]:.0f} | {sec[t]:.2f} | {x_cpu} | {infeasible[t]} |")
    return "\n".join(lines)


def _map_source(name: str) -> Any:
    """A record's map from its name: a generated map's arguments, or a suite task."""
    if name.startswith("gen-"):
        from planner_core.suite import generate_map

        size, density, seed = name[4:].split("-")
        return generate_map(int(size), int(density[1:]), int(seed[1:]))
    if "-s" in name:  # a large suite map from another seed
        task, seed = name.split("-s")
        return large_maps([task], int(seed))[0][1]
    return (LARGE if (LARGE / f"{name}.json").exists() else SUITE) / f"{name}.json"


def _fill_features(records: list[dict[str, Any]]) -> None:
    """Recompute the features of records written without them (runs each case's prefix)."""
    from planner_core.model.mapio import load_map
    from planner_core.model.problem import Problem
    from planner_core.pipeline import DEFAULT_PIPELINE, PlanConfig
    from planner_core.pipeline.pipeline import PipelineRun

    cache: dict[tuple[str, int, int], dict[str, float]] = {}
    problems: dict[str, Any] = {}
    for r in records:
        if r.get("features"):
            continue
        key = (r["map"], r["seed"], r["budget"])
        if key not in cache:
            if r["map"] not in problems:
                problems[r["map"]] = Problem(load_map(_map_source(r["map"])).planning_map())
            problem = problems[r["map"]]
            run = PipelineRun(problem, PlanConfig(seed=r["seed"], budget=r["budget"]),
                              pipeline=DEFAULT_PIPELINE, evaluator=None, progress=None)
            run.advance(until="improve")
            cache[key] = case_features(problem, run)
        r["features"] = cache[key]


def select(records: list[dict[str, Any]], k: int = 5) -> str:
    """The contextual selector (`planner_core.learning.schedule_select`) evaluated
    leave-one-map-out on `records`: for each held-out map, the template predicted from the
    `k` nearest cases of the other maps, against the best static template of those maps and
    the default (the per-case oracle is 0)."""
    import numpy as np

    from planner_core.learning.schedule_select import fit

    _fill_features(records)
    table = fit(records, k=k)
    cv = table.meta["cross_validation"][str(k)]
    d = table.templates.index("default")
    return (f"leave-one-map-out over {len(set(table.maps))} maps, {cv['cases']} cases, "
            f"k = {k}\n"
            f"mean gap to the per-case best (%): selector {cv['selector']:.4f}, best static "
            f"(chosen on the training maps) {cv['static']:.4f}, default "
            f"{float(np.mean(table.gaps[:, d])):.4f}, oracle 0; selector better / worse than "
            f"the best static on {cv['better']} / {cv['worse']} cases")


def other_seed_choice(records: list[dict[str, Any]]) -> str:
    """The per-map oracle validated on held-out seeds: for each case, the template that was
    best on the same map's other seeds (least mean gap), against the best static template of
    all cases, and the mean correlation of the templates' gaps between two seeds of a map.
    Where this choice is no better than the static one, what a template gains on a map is
    its seed's noise, and no map feature can predict it."""
    import numpy as np

    from planner_core.learning.schedule_select import cases_from_records

    keys, _, G, templates = cases_from_records(records)
    maps = np.array([m for m, _ in keys])
    s = int(np.argmin(G.mean(0)))
    chosen, static, corr = [], [], []
    for m in np.unique(maps):
        idx = np.flatnonzero(maps == m)
        for i in idx if len(idx) > 1 else []:
            others = idx[idx != i]
            chosen.append(G[i, int(np.argmin(G[others].mean(0)))])
            static.append(G[i, s])
        if len(idx) > 1 and G[idx[0]].std() > 0 and G[idx[1]].std() > 0:
            corr.append(np.corrcoef(G[idx[0]], G[idx[1]])[0, 1])
    c, st = np.array(chosen), np.array(static)
    return (f"per-map choice from the map's other seeds: mean gap {c.mean():.4f} % against the "
            f"best static ({templates[s]}) {st.mean():.4f} % on {len(c)} cases; better / worse "
            f"on {int((c < st).sum())} / {int((c > st).sum())}; mean correlation of the "
            f"templates' gaps between a map's first two seeds {np.mean(corr):.3f} "
            f"({len(corr)} maps)")


def _paired(d: Any, maps: Any, rng: Any) -> tuple[float, float, float, list[float]]:
    """The paired statistics of per-case differences d (n,) on cases of maps (n,): the
    Wilcoxon signed-rank p (two-sided, zero differences dropped; 1 when all are 0), a
    bootstrap 95 % CI of the mean (10,000 resamples of the cases drawn from `rng`), and the
    mean difference of each map (sorted by map)."""
    import numpy as np
    from scipy.stats import wilcoxon

    p = wilcoxon(d).pvalue if np.any(d) else 1.0
    boot = d[rng.integers(0, len(d), size=(10_000, len(d)))].mean(1)
    lo, hi = np.percentile(boot, [2.5, 97.5])
    return float(p), float(lo), float(hi), [d[maps == m].mean() for m in np.unique(maps)]


def evaluate(table_dir: str, records: list[dict[str, Any]], seed: int = 0) -> str:
    """A fitted selector table (`python -m planner_core.learning.schedule_select fit`) on
    held-out grid records: per case the template the table picks from the case's features
    (what `--scheduler lamde-s` follows on maps of the paper's sizes; beyond them it follows
    the default), against the table's best static template, the
    default and the per-case oracle. Prints mean gaps, the paired Wilcoxon signed-rank test
    selector vs best static (two-sided, zero differences dropped), a bootstrap 95 % CI of the
    mean difference (10,000 resamples of the cases, `seed`), the share of maps whose mean gap
    over their seeds is lower than the static one's (of the maps where they differ), and the
    improving stage's seconds against the default's."""
    import numpy as np

    from planner_core.learning.schedule_select import SelectorTable, cases_from_records

    table = SelectorTable.load(table_dir)
    keys, F, G, templates = cases_from_records(records)
    idx = {t: i for i, t in enumerate(templates)}
    picks = [table.predict(v) for v in F]
    sel = np.array([G[i, idx[p]] for i, p in enumerate(picks)])
    static = G[:, idx[table.templates[0]]]
    default = G[:, idx["default"]]
    diff = sel - static
    maps = np.array([m for m, _ in keys])
    p, lo, hi, per_map = _paired(diff, maps, np.random.default_rng(seed))
    n_diff = sum(1 for v in per_map if v != 0)
    secs: dict[tuple[str, int], dict[str, float]] = {}
    for r in records:
        secs.setdefault((r["map"], r["seed"]), {})[r["template"]] = r["improve_seconds"]
    t_sel = sum(secs[k_][pk] for k_, pk in zip(keys, picks, strict=True))
    t_def = sum(secs[k_]["default"] for k_ in keys)
    n_cases = len({(r["map"], r["seed"]) for r in records})
    rel = (sel.mean() / static.mean() - 1) * 100 if static.mean() else 0.0
    counts = {t: picks.count(t) for t in table.templates if picks.count(t)}
    return "\n".join([
        f"{len(keys)} held-out cases on {len(np.unique(maps))} maps ({n_cases - len(keys)} "
        f"left out: a template infeasible or missing); table {table_dir}: "
        f"{len(table.gaps)} training cases, k = {table.k}",
        f"mean gap to the per-case best (%): lamde-s {sel.mean():.4f}, best static "
        f"({table.templates[0]}) {static.mean():.4f}, default {default.mean():.4f}, oracle 0",
        f"lamde-s vs best static: {rel:+.1f} % "
        f"of its mean gap; better / worse on {int((diff < 0).sum())} / {int((diff > 0).sum())} "
        f"cases, Wilcoxon p = {p:.3g}; mean difference {diff.mean():+.4f} points, 95 % CI "
        f"[{lo:+.4f}, {hi:+.4f}]",
        f"maps where lamde-s's mean is lower: {sum(v < 0 for v in per_map)} of {n_diff} that "
        f"differ ({len(per_map)} maps)",
        f"improving stage: lamde-s {t_sel:.1f} s against the default's {t_def:.1f} s "
        f"({t_sel / t_def if t_def else 0:.2f}x)",
        "picks: " + ", ".join(f"{t} {c}" for t, c in counts.items()),
    ])


def evaluate_split(table_dir: str, records: list[dict[str, Any]], seed: int = 0) -> str:
    """A fitted split table (`python -m planner_core.learning.schedule_select fit-split`) on
    held-out `--splits` records: per case the DE share the table picks from the map's
    features (what `--scheduler lamde-s` runs with), against the table's best static share
    (the least mean gap on its training cases among the shares within its CPU cap) and the
    default share. Prints the mean gap to the per-case best share, the mean f difference in
    per cent of f, the paired Wilcoxon signed-rank test (two-sided, zero differences
    dropped) and a bootstrap 95 % CI of the mean difference (10,000 resamples, `seed`), the
    maps whose mean over their seeds is lower, and the mean CPU of the whole plan over the
    default share's; where the records hold lamde-s's own runs (arm "lamde-s"), how often
    they equal the picked share's plan."""
    import numpy as np

    from planner_core.learning.schedule_select import (
        SPLIT_FEATURES,
        SplitTable,
        capped_best,
        split_cases,
    )

    table = SplitTable.load(table_dir)
    if table is None:
        raise ValueError(f"{table_dir}: no split table (split.npz)")
    keys, F, G, C, splits = split_cases(records)
    if not len(keys):
        raise ValueError("records: no case where every split ran and was feasible")
    missing = [x for x in table.splits if x not in splits]
    if missing:
        raise ValueError(f"records: no runs at the table's shares {missing} (run "
                         f"--splits {' '.join(f'{x:g}' for x in table.splits)})")
    col = {x: i for i, x in enumerate(splits)}
    picks = [table.predict(v) for v in F]
    static_share = table.splits[capped_best(table.gaps, table.cpu, table.cap)]
    f = {(r["map"], r["seed"], float(r["de_share"])): r["f"] for r in records
         if r.get("template") == "default" and "de_share" in r}
    i_pick = np.array([col[x] for x in picks])
    rows = np.arange(len(keys))
    sel, static, default = G[rows, i_pick], G[:, col[static_share]], G[:, 0]
    f_sel = np.array([f[(m, sd, x)] for (m, sd), x in zip(keys, picks, strict=True)])
    f_static = np.array([f[(m, sd, static_share)] for m, sd in keys])
    f_def = np.array([f[(m, sd, splits[0])] for m, sd in keys])
    d_static = (f_sel / f_static - 1) * 100
    d_def = (f_sel / f_def - 1) * 100
    out = [f"{len(keys)} held-out cases on {len({m for m, _ in keys})} maps; split table "
           f"{table_dir}: {len(table.gaps)} training cases, k = {table.k}, cap "
           f"{table.cap:g}x CPU, features {', '.join(SPLIT_FEATURES)}",
           f"mean gap to the per-case best share (%): lamde-s {sel.mean():.4f}, best static "
           f"({static_share:g}) {static.mean():.4f}, default ({splits[0]:g}) "
           f"{default.mean():.4f}, oracle 0"]
    rng = np.random.default_rng(seed)
    maps = np.array([m for m, _ in keys])
    for name, d in (("best static", d_static), ("default", d_def)):
        p, lo, hi, per_map = _paired(d, maps, rng)
        out.append(f"lamde-s vs {name}: f {d.mean():+.3f} % on average, 95 % CI "
                   f"[{lo:+.3f}, {hi:+.3f}]; lower / higher on {int((d < 0).sum())} / "
                   f"{int((d > 0).sum())} cases, Wilcoxon p = {p:.3g}; maps with a lower "
                   f"mean {sum(v < 0 for v in per_map)} of {len(per_map)}")
    out.append(f"whole-plan CPU over the default share's: lamde-s {C[rows, i_pick].mean():.2f}x "
               f"(max {C[rows, i_pick].max():.2f}x), best static "
               f"{C[:, col[static_share]].mean():.2f}x")
    out.append("picks: " + ", ".join(f"{x:g} {picks.count(x)}" for x in splits
                                     if picks.count(x)))
    own = {(r["map"], r["seed"]): r for r in records if r.get("arm") == "lamde-s"}
    if own:
        same = sum(1 for k_, x in zip(keys, picks, strict=True) if k_ in own
                   and own[k_]["de_share"] == x and own[k_]["f"] == f[(*k_, x)])
        out.append(f"lamde-s's own runs: {len(own)}; the picked share's plan in {same} of "
                   f"{sum(1 for k_ in keys if k_ in own)} complete cases")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    """The command line (module docstring). Returns the exit status (2: bad arguments)."""
    from planner_core.pipeline.schedule import LEARNED, make_scheduler, scheduler_names

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", type=int, default=24, help="generated training maps (24)")
    ap.add_argument("--map-seed", type=int, default=3400, help="first generated map's seed")
    ap.add_argument("--suite", nargs="*", metavar="TASK",
                    help="the suite's maps (all 16 without names) instead of generated ones")
    ap.add_argument("--large", nargs="*", metavar="TASK",
                    help="the large suite's maps (examples/maps/large, all 8 without names) "
                    "instead of generated ones")
    ap.add_argument("--large-seed", type=int, metavar="S",
                    help="with --large: the large suite's specs drawn from generator seed S "
                    "(held-out maps named L01-sS ...) instead of the committed maps")
    ap.add_argument("--seeds", type=int, default=2, help="plan seeds 0..N-1 (2)")
    ap.add_argument("--budget", type=int, default=10_000, help="evaluations a plan (10,000)")
    ap.add_argument("--templates", nargs="+",
                    default=[t for t in scheduler_names() if t not in ("alternate", *LEARNED)],
                    help="schedules to compare (default: all registered but 'alternate', "
                    "which is the default's cycle written out, and the learned ones); a "
                    "learned one may name its checkpoint folder: lamde-s-ppo:DIR")
    ap.add_argument("--splits", nargs="+", type=float, metavar="SHARE",
                    help="DE shares to run each template at (e.g. 0.6 0.4 0.3): the prefix "
                    "stops before the DE; a learned scheduler with a split table (lamde-s) "
                    "runs once at the share it picks; records for the split table's fit")
    ap.add_argument("--jobs", type=int, default=0,
                    help="run the cases on N worker processes (0: in this process)")
    ap.add_argument("--backend", choices=("local", "ray"), default="local",
                    help="executor for --jobs (local processes or a Ray cluster)")
    ap.add_argument("-o", "--output", help="JSON lines file to write the runs to")
    ap.add_argument("--summary", nargs="+", metavar="JSONL",
                    help="print the table of earlier records (plain or .gz) and exit")
    ap.add_argument("--evaluate", nargs="+", metavar=("TABLE", "JSONL"),
                    help="a fitted selector table directory, then held-out records: print "
                    "the selector against the best static schedule and exit")
    ap.add_argument("--evaluate-split", nargs="+", metavar=("TABLE", "JSONL"),
                    help="a fitted split table directory, then held-out --splits records: "
                    "print the share it picks against the best static share and exit")
    ap.add_argument("--select", nargs="+", metavar="JSONL",
                    help="evaluate the contextual selector on earlier records (leave one map "
                    "out) and exit")
    args = ap.parse_args(argv)
    if args.summary:
        print(summarise(_read(args.summary)))
        return 0
    if args.evaluate:
        if len(args.evaluate) < 2:
            print("bench_schedule: --evaluate: needs TABLE and at least one JSONL",
                  file=sys.stderr)
            return 2
        try:
            print(evaluate(args.evaluate[0], _read(args.evaluate[1:])))
        except (OSError, ValueError, KeyError) as exc:  # e.g. --splits records, other arms
            print(f"bench_schedule: --evaluate: records lack a template the table needs "
                  f"({exc}); --evaluate-split scores --splits records" if isinstance(
                      exc, KeyError) else f"bench_schedule: --evaluate: {exc}", file=sys.stderr)
            return 2
        return 0
    if args.evaluate_split:
        try:
            if len(args.evaluate_split) < 2:
                raise ValueError("needs TABLE and at least one JSONL")
            print(evaluate_split(args.evaluate_split[0], _read(args.evaluate_split[1:])))
        except (OSError, ValueError, KeyError) as exc:
            print(f"bench_schedule: --evaluate-split: {exc}", file=sys.stderr)
            return 2
        return 0
    if args.select:
        records = _read(args.select)
        print(select(records))
        print(other_seed_choice(records))
        if args.output:  # the records with their features, for the next --select
            with open(args.output, "w") as fh:
                fh.writelines(json.dumps(r) + "\n" for r in records)
        return 0
    bad = [t for t in args.templates if t not in scheduler_names()
           and t.partition(":")[0] not in LEARNED]
    for t in args.templates:  # a learned one's checkpoint loads before any run
        if t not in bad:
            try:
                make_scheduler(t)
            except ValueError as exc:
                print(f"bench_schedule: --templates: {exc}", file=sys.stderr)
                return 2
    if bad or args.maps < 1 or args.seeds < 1:
        print(f"bench_schedule: --templates: unknown {bad}" if bad else
              "bench_schedule: --maps and --seeds: must be >= 1", file=sys.stderr)
        return 2
    if args.jobs < 0:
        print(f"bench_schedule: --jobs: must be >= 0, got {args.jobs}", file=sys.stderr)
        return 2
    if args.splits is not None and not all(0.0 <= x <= 1.0 for x in args.splits):
        print(f"bench_schedule: --splits: each must be in [0, 1], got {args.splits}",
              file=sys.stderr)
        return 2
    if args.suite is not None and args.large is not None:
        print("bench_schedule: --suite and --large: choose one", file=sys.stderr)
        return 2
    if args.large_seed is not None and (args.large is None or args.large_seed < 0):
        print("bench_schedule: --large-seed: needs --large and a seed >= 0", file=sys.stderr)
        return 2
    from planner_core.suite import generated_maps

    maps = (suite_maps(args.suite) if args.suite is not None
            else large_maps(args.large, args.large_seed) if args.large is not None
            and args.large_seed is not None
            else suite_maps(args.large, LARGE) if args.large is not None
            else generated_maps(args.maps, args.map_seed))
    out = open(args.output, "w") if args.output else None  # noqa: SIM115
    try:
        records = run_grid(maps, list(range(args.seeds)), args.budget, args.templates, out,
                           splits=args.splits, jobs=args.jobs, backend=args.backend)
    finally:
        if out is not None:
            out.close()
    print(summarise(records))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

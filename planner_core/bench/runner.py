"""The benchmark runner: every optimiser x task x run on the same budget, resumable.

Each (optimiser, task, run) is one job with its own seed (derived from the base seed, the task
name and the run index; the same for every optimiser, so all see the same seeds). A job carries
its map's JSON content (not its path), so any worker, on any machine, can run it. Jobs go through
an executor (`planner_core.execution`); results stream back and each finished run is appended
to `<out>/results.jsonl` at once, so an interrupted benchmark resumes where it stopped.
`<out>/meta.json` records the suite (as given, and its absolute path for a report made from
another folder), budget and every command that wrote to the folder. Feasible
runs that beat the best-known f of their task update the best-known file beside the suite.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
import traceback
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from planner_core import defaults as _defaults
from planner_core.bench._io import read_meta, stored_path, utc_now, write_json_atomic
from planner_core.bench.limits import BestKnown, best_known_path, suite_task_files
from planner_core.bench.records import (
    RESULTS_FILE,
    Key,
    ResultsWriter,
    key_of,
    read_records,
    skipped_note,
)
from planner_core.execution import Executor, executor_problem, make_executor
from planner_core.textio import counted, for_count

__all__ = [
    "BEST_KNOWN_BUDGET",
    "BEST_KNOWN_OPTIMISERS",
    "BEST_KNOWN_RUNS",
    "BenchError",
    "BenchSummary",
    "Job",
    "META_FILE",
    "HISTORY_POINTS",
    "execute",
    "plan_jobs",
    "read_map_file",
    "run_bench",
    "run_seed",
    "with_i_max",
    "downsample",
]

META_FILE = "meta.json"
#: the best-known protocol: 100 x the paper's budget, 5 runs each, the strongest optimisers
BEST_KNOWN_BUDGET = _defaults.BEST_KNOWN_BUDGET
BEST_KNOWN_RUNS = _defaults.BEST_KNOWN_RUNS
BEST_KNOWN_OPTIMISERS = ("cmaes", "de-adaptive", "de-adaptive-fixedlen")
#: convergence checkpoints stored per run (evenly spaced over the budget, plus the first)
HISTORY_POINTS = 100
SCHEMA = 1


class BenchError(ValueError):
    """A benchmark request that cannot be carried out as asked (message says why)."""


@dataclass(frozen=True, eq=False)
class Job:
    """One run: which optimiser on which map, with which seed and budget.

    ``map`` is the map file's parsed JSON content (what `planner_core.load_map` accepts), so the
    job is complete in itself: a worker never opens a file. ``map_sha256`` is the SHA-256 of
    the file's bytes, recorded with the result (a resumed benchmark refuses a changed map).
    """

    optimiser: str
    task: str
    run: int
    seed: int
    budget: int
    map: dict[str, Any]
    map_sha256: str
    init: str = "seeded"
    i_max: int | None = None  # None: the map's own I_max; else uav.max_hover_points overridden
    spec: Any = None  # an OptimiserSpec outside the registry (run_bench's `extra`), else None


@dataclass
class BenchSummary:
    """What a call to `run_bench` did."""

    planned: int = 0  # jobs this call had to run
    skipped: int = 0  # already in the results file
    done: int = 0
    failed: list[dict[str, Any]] = field(default_factory=list)
    best_known_updates: list[str] = field(default_factory=list)
    results: Path | None = None


def run_seed(base_seed: int, task: str, run: int) -> int:
    """Seed of run `run` on `task`: independent across runs and tasks, stable across calls
    (`numpy.random.SeedSequence` of the base seed, the task name's CRC-32 and the run).

    Args:
        base_seed: the benchmark's base seed.
        task: the task name.
        run: the run index.

    Returns:
        The seed, in [0, 2**31 - 1).
    """
    ss = np.random.SeedSequence([int(base_seed), zlib.crc32(task.encode()), int(run)])
    return int(ss.generate_state(1)[0] % (2**31 - 1))


def downsample(evaluations: np.ndarray, values: list[np.ndarray], budget: int,
               points: int = HISTORY_POINTS) -> tuple[np.ndarray, list[np.ndarray]]:
    """Keep the trace entries current at `points` evenly spaced evaluation counts (and the first
    and last entries): a step function the report can put on a common grid.

    Args:
        evaluations: (n,) evaluation counts of the trace, ascending.
        values: arrays of length n (best f, best phi) sampled alongside.
        budget: the run's evaluation budget (the grid ends there).
        points: grid points, evenly spaced over (0, budget].

    Returns:
        (kept evaluation counts, the kept entries of each of `values`), each of length
        <= points + 2; an empty trace is returned as it is.
    """
    ev = np.asarray(evaluations)
    if ev.size == 0:
        return ev, [np.asarray(v) for v in values]
    grid = np.linspace(budget / points, budget, points)
    idx = np.searchsorted(ev, grid, side="right") - 1
    idx = np.unique(np.concatenate([[0], idx[idx >= 0], [ev.size - 1]]))
    return ev[idx], [np.asarray(v)[idx] for v in values]


def _floats(a: Any) -> list[Any]:
    return np.asarray(a, dtype=float).tolist()


#: the modules whose entries run our DE (their kwargs name its configurator, else the default)
_DE_MODULES = ("planner_core.bench.baselines.de", "planner_core.bench.baselines.eng_start")


def _configurator_of(spec: Any) -> str | None:
    """The DE configurator an entry runs (a registry name), or None for an entry that does not
    run our DE (`warm_kernels` then warms the shared kernels only)."""
    if spec.target.split(":")[0] not in _DE_MODULES:
        return None
    return str(spec.kwargs.get("configurator", _defaults.CONFIGURATOR))


def execute(job: Job) -> dict[str, Any]:
    """Run one job and return its record (or an error record with the traceback); top-level,
    so worker processes can unpickle it. Wall and CPU time exclude a warm-up: the optimiser's
    imports, the compiled kernels it needs (`planner_core.pipeline.warmup.warm_kernels`, once
    per process and configurator: the process's first run pays the compile, untimed) and one
    evaluation.

    Args:
        job: the run: optimiser, task, seed, budget, the map's content, start mode, I_max.

    Returns:
        The run record: the job's identity plus "score" (f + 10 phi), "f" (s), "phi",
        "feasible", "evaluations", "wall_s", "cpu_s", "n_hover", "n_points",
        "last_feasible_rate", "hover_points", "hover_times", "x" and the downsampled
        "history"; or, when anything raised, the identity plus "error" and "traceback" (the
        exception is not raised: one broken run must not end the benchmark).
    """
    from planner_core.bench.baselines import get, optimise, problem_for
    from planner_core.model.formulas import penalised_score
    from planner_core.model.mapio import load_map
    from planner_core.model.problem import Problem
    from planner_core.pipeline.warmup import warm_kernels

    base = {"optimiser": job.optimiser, "task": job.task, "run": job.run, "seed": job.seed,
            "budget": job.budget, "map_sha256": job.map_sha256, "init": job.init}
    if job.i_max is not None:
        base["i_max"] = int(job.i_max)
    try:
        # a map's safety margins are a transformation of the map (zero on the suite maps,
        # which say so: the paper's model as it stands)
        spec = job.spec or get(job.optimiser)
        problem = problem_for(job.optimiser,
                              Problem(load_map(with_i_max(job.map, job.i_max)).planning_map()),
                              spec)
        # warm up outside the timer: import the optimiser's module (cma, scipy), compile (or
        # load from numba's disk cache) the kernels it runs, once per process (`warm_kernels`:
        # 19-27 s of a worker's first run on an empty cache), and one evaluation of this map,
        # so wall time measures the optimiser alone
        spec.function()
        warm_kernels(_configurator_of(spec))
        problem.evaluate(problem.lower[None, :])
        t0, c0 = time.perf_counter(), time.process_time()
        res = optimise(job.optimiser, problem, job.budget, job.seed, init=job.init,
                       spec=job.spec)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        bd = problem.breakdown(res.x)
        h = res.history
        ev, (bf, bp) = downsample(h.evaluations, [h.best_f, h.best_phi], job.budget)
        return {
            **base,
            "schema": SCHEMA,
            "score": float(penalised_score(res.f, res.phi)),
            "f": float(res.f),
            "phi": float(res.phi),
            "feasible": bool(res.phi == 0.0),
            "evaluations": int(res.evaluations),
            "wall_s": round(wall, 4),
            "cpu_s": round(cpu, 4),  # the worker's CPU time: wall_s less the waits of a busy CPU
            "n_hover": int(bd["n_hover"]),
            "n_points": int(problem.n_points),
            "last_feasible_rate": (None if res.last_feasible_rate is None
                                   else float(res.last_feasible_rate)),
            "hover_points": bd["hover_points"],
            "hover_times": bd["hover_times"],
            "x": _floats(res.x),
            "history": {"evaluations": ev.astype(int).tolist(), "best_f": _floats(bf),
                        "best_phi": _floats(bp)},
        }
    except Exception as exc:  # one broken run must not end the benchmark
        return {**base, "error": f"{type(exc).__name__}: {exc}",
                "traceback": traceback.format_exc()}


def with_i_max(content: dict[str, Any], i_max: int | None) -> dict[str, Any]:
    """The map content with `uav.max_hover_points` (I_max) set to `i_max` (None: unchanged);
    a copy, the original is not touched.

    Args:
        content: a map file's parsed JSON content.
        i_max: the I_max override, or None.

    Returns:
        `content` itself for None, else a shallow copy with a new "uav" object.
    """
    if i_max is None:
        return content
    out = dict(content)
    out["uav"] = {**dict(content.get("uav") or {}), "max_hover_points": int(i_max)}
    return out


def plan_jobs(files: dict[str, Path], optimisers: list[str], runs: int, budget: int,
              base_seed: int = 0, inits: Sequence[str] = ("seeded",),
              i_max: Sequence[int | None] = (None,),
              specs: dict[str, Any] | None = None) -> list[Job]:
    """All jobs, run-major (every task, optimiser, start mode and I_max gets run 0 before any
    gets run 1), so a partial benchmark is balanced. Each map file is read once; its jobs share
    the content. Run r of task t has the same seed in every start mode and I_max.

    Args:
        files: task name -> map file.
        optimisers: optimiser names.
        runs: runs per cell.
        budget: evaluations per run.
        base_seed: the base seed of `run_seed`.
        inits: start modes.
        i_max: I_max overrides (None: the map's own).
        specs: OptimiserSpecs of names outside the registry, carried by their jobs.

    Returns:
        The `Job`s, runs x tasks x inits x i_max x optimisers of them.

    Raises:
        BenchError: a map file that is not JSON or not an object (`read_map_file`).
        OSError: a map file that cannot be read.
    """
    content = {t: read_map_file(p) for t, p in files.items()}
    specs = specs or {}
    return [
        Job(o, t, r, run_seed(base_seed, t, r), int(budget), *content[t], init=m, i_max=k,
            spec=specs.get(o))
        for r in range(runs)
        for t in files
        for m in inits
        for k in i_max
        for o in optimisers
    ]


def _spec_json(spec: Any) -> dict[str, Any]:
    """What meta.json records of an optimiser entry outside the registry."""
    return {"description": spec.description, "target": spec.target,
            "kwargs": dict(spec.kwargs), "variable_length": spec.variable_length,
            "probe_evaluations": int(spec.probe_evaluations)}


def read_map_file(path: str | Path) -> tuple[dict[str, Any], str]:
    """A map file's parsed JSON content and the SHA-256 of its bytes, from one read.

    Args:
        path: the map file.

    Returns:
        (parsed JSON content, hex SHA-256 of the bytes).

    Raises:
        BenchError: not valid JSON, or its top level is not an object.
        OSError: the file cannot be read.
    """
    data = Path(path).read_bytes()
    try:
        content = json.loads(data)
    except ValueError as exc:
        raise BenchError(f"{path}: not valid JSON ({exc})") from None
    if not isinstance(content, dict):
        raise BenchError(f"{path}: the top level must be a JSON object")
    return content, hashlib.sha256(data).hexdigest()


def _imax_tag(rec: dict[str, Any]) -> str:
    return "" if rec.get("i_max") is None else f" I_max {rec['i_max']}"


def _check_existing(records: list[dict[str, Any]], budget: int, shas: dict[str, str],
                    results: Path) -> None:
    budgets = {int(r["budget"]) for r in records if "budget" in r}
    if budgets and budgets != {int(budget)}:
        raise BenchError(
            f"{results} holds runs with budget {sorted(budgets)}, not {budget}: "
            "use another --out folder for a different budget"
        )
    for r in records:
        t = r.get("task")
        if t in shas and r.get("map_sha256") not in (None, shas[t]):
            raise BenchError(
                f"{results}: task {t} was run on a different version of its map file "
                "(SHA-256 differs): use another --out folder"
            )


def run_bench(
    suite: str | Path,
    optimisers: list[str],
    *,
    runs: int,
    budget: int,
    out: str | Path,
    tasks: list[str] | None = None,
    jobs: int = 1,
    base_seed: int = 0,
    best_known: str | Path | None | bool = True,
    command: str = "",
    executor: Executor | None = None,
    backend: str = "local",
    address: str | None = None,
    log: Callable[[str], None] | None = None,
    inits: Sequence[str] = ("seeded",),
    i_max: Sequence[int | None] = (None,),
    extra: Sequence[Any] = (),
) -> BenchSummary:
    """Run every missing (optimiser, task, run, init, I_max) and append each result to
    `<out>/results.jsonl`.

    `executor` overrides `jobs`, `backend` and `address`; without it the executor is
    `planner_core.execution.make_executor(jobs, backend, address)`, closed when the benchmark
    ends. Results are the same on every backend. Every file is read (and refused, one line
    naming it) before anything is written; then `<out>/meta.json` records the command.

    Args:
        suite: the suite folder of map files.
        optimisers: optimiser names (the registry's or `extra`'s).
        runs: runs per cell, 1 to `planner_core.defaults.MAX_RUNS`.
        budget: evaluations per run, an integer in [1, `planner_core.defaults.MAX_BUDGET`].
        out: the output folder.
        tasks: the tasks to run (None: every map of the suite).
        jobs: local: 0 = in this process, N = N worker processes; ray: CPUs of a local Ray
            instance.
        base_seed: base seed of `run_seed`, >= 0.
        best_known: True = `<suite>_best_known.json` beside the suite folder, a path = that
            file, None/False = no updates.
        command: the command line recorded in meta.json and with best-known updates.
        executor: an executor to run the jobs on (not closed here).
        backend: "local" or "ray" (`make_executor`).
        address: a Ray cluster's address (ray: a Ray cluster at `address`, or a local Ray
            instance with `jobs` CPUs).
        log: receives progress lines and notes.
        inits: start modes (`planner_core.bench.baselines.INIT_MODES`: "seeded" the
            product's, "uniform" the paper's protocol).
        i_max: I_max values to override the maps' own with (None = the map's; the I_max
            study, paper Fig. 4), each in [1, 200].
        extra: OptimiserSpecs outside the registry (`planner_core.bench.baselines.policy_spec`:
            the ablation variants), runnable under their names; `<out>/meta.json` records each
            one's target, arguments, encoding and probe count, and a resumed benchmark refuses a
            name whose entry changed.

    Returns:
        The `BenchSummary`: jobs planned and skipped, runs done, failed runs' error records,
        tasks whose best-known entry improved, the results file.

    Raises:
        BenchError: an unknown start mode, optimiser or task, an I_max outside [1, 200], an
            extra name that shadows the registry, runs, budget or base seed out of range, an
            empty suite, an unreadable results, meta or best-known file, or an output folder
            holding runs of another budget, base seed, map version or optimiser entry, or
            its runs only compressed (results.jsonl.gz: read-only), a missing suite folder,
            or (without `executor`) a bad `jobs` or `backend`, an address with local or the
            ray backend without Ray installed (`executor_problem`), each refused before
            anything is written.
    """
    from planner_core.bench.baselines import INIT_MODES, REGISTRY, missing_extras

    log = log or (lambda _msg: None)
    bad = [m for m in inits if m not in INIT_MODES]
    if bad or not inits:
        raise BenchError(f"init: unknown {for_count(len(bad), 'start mode')} "
                         f"{', '.join(bad) or '(none given)'}; "
                         f"choose from {', '.join(INIT_MODES)}")
    if any(k is not None and not 1 <= int(k) <= 200 for k in i_max):
        raise BenchError(f"i_max: every value must lie in [1, 200] (got {list(i_max)})")
    extras = {e.name: e for e in extra}
    clash = [n for n in extras if n in REGISTRY]
    if clash:
        raise BenchError(f"extra {for_count(len(clash), 'optimiser')} {', '.join(clash)} "
                         f"{for_count(len(clash), 'shadows', 'shadow')} registry names")
    unknown = [o for o in optimisers if o not in REGISTRY and o not in extras]
    if unknown:
        raise BenchError(f"unknown {for_count(len(unknown), 'optimiser')} "
                         f"{', '.join(unknown)}; choose from "
                         f"{', '.join([*REGISTRY, *extras])}")
    lacking = missing_extras(optimisers, extra)  # before any run, not one failure per run
    if lacking:
        raise BenchError(f"optimisers: {lacking}")
    if not 1 <= runs <= _defaults.MAX_RUNS:
        raise BenchError(f"runs must be an integer in [1, {_defaults.MAX_RUNS:,}], got {runs}")
    try:
        _defaults.check_budget(budget, 1, least_name=None)
    except ValueError as exc:
        raise BenchError(str(exc)) from None
    if int(base_seed) < 0:
        raise BenchError(f"base_seed must be an integer >= 0, got {base_seed}")
    if executor is None:  # refused here, before meta.json is written
        problem = executor_problem(jobs, backend, address)
        if problem is not None:
            raise BenchError(problem)
    try:
        files = suite_task_files(suite)
    except FileNotFoundError:
        raise BenchError(f"suite {suite}: no such folder of map files") from None
    if not files:
        raise BenchError(f"no map files in {suite}")
    if tasks:
        missing = [t for t in tasks if t not in files]
        if missing:
            raise BenchError(f"{for_count(len(missing), 'task')} {', '.join(missing)} not in "
                             f"{suite} "
                             f"(have {', '.join(files)})")
        files = {t: files[t] for t in tasks}
    out = Path(out)
    results = out / RESULTS_FILE
    if not results.exists() and stored_path(results) != results:  # new runs would go to a
        # plain results.jsonl beside it, which readers then prefer: the stored runs lost
        raise BenchError(f"out {out}: holds {stored_path(results).name}, runs stored "
                         "compressed (read-only): gunzip it to add runs there, or use another "
                         "out folder")
    bk: BestKnown | None = None
    bk_path = None
    try:  # every file read is refused (one line naming it) before anything is written
        existing = read_records(results)
        meta = read_meta(out)
        if best_known:
            bk_path = best_known_path(suite) if best_known is True else Path(best_known)
            bk = BestKnown(bk_path)
            bk.load()
    except BenchError:
        raise
    except ValueError as exc:
        raise BenchError(str(exc)) from None
    note = skipped_note(results, existing)
    if note is not None:  # the runs of lines not read are missing: planned again below
        log(note)
    all_jobs = plan_jobs(files, list(optimisers), runs, budget, base_seed, inits, i_max,
                         extras)
    _check_existing(existing.records, budget, {j.task: j.map_sha256 for j in all_jobs}, results)
    have: set[Key] = {key_of(r) for r in existing.records}
    todo = [j for j in all_jobs
            if Key(j.optimiser, j.task, j.run, j.init, j.i_max) not in have]
    summary = BenchSummary(planned=len(todo), skipped=len(all_jobs) - len(todo), results=results)

    seeds = {Key(j.optimiser, j.task, j.run, j.init, j.i_max): j.seed for j in all_jobs}
    other = next((r for r in existing.records if r.get("seed") is not None
                  and seeds.get(key_of(r), r["seed"]) != r["seed"]), None)  # fmt: skip
    meta_path = out / META_FILE
    if other is not None or meta.get("base_seed") not in (None, int(base_seed)):
        was = meta.get("base_seed", "another")
        raise BenchError(f"{results} holds runs of base seed {was}, not {base_seed}: "
                         "use another --out folder for another seed")
    if meta.get("budget") not in (None, int(budget)):
        raise BenchError(f"{meta_path} records budget {meta['budget']}, not {budget}: "
                         "use another --out folder")
    entries = meta.setdefault("optimisers", {})
    for name in optimisers:
        if name in extras:
            entry = _spec_json(extras[name])
            if entries.get(name, entry) != entry:
                raise BenchError(f"{meta_path}: optimiser {name} was run as {entries[name]}, "
                                 f"not {entry}: use another --out folder")
            entries[name] = entry
    if not entries:
        del meta["optimisers"]
    # the suite as given (shown in reports) and absolute (found by a report made elsewhere)
    meta.update({"schema": SCHEMA, "suite": str(suite),
                 "suite_absolute": str(Path(suite).resolve()), "budget": int(budget),
                 "base_seed": int(base_seed),
                 # wall_s / cpu_s leave out each process's kernel compile (`execute`)
                 "wall_excludes_compile": True})
    meta.setdefault("commands", []).append({"command": command, "started": utc_now(),
                                            "jobs_planned": len(todo)})
    write_json_atomic(meta_path, meta)

    best: dict[str, float] = {}
    if bk is not None:
        if not bk.path.exists():
            log(f"note: {bk_path} does not exist: a new best-known file starts from the maps' "
                "witness plans (a run's 'best-known improved' is against those)")
        try:
            best = bk.ensure(files)
        except BenchError:
            raise
        except ValueError as exc:  # the file changed since it was read
            raise BenchError(str(exc)) from None
    log(f"{counted(len(all_jobs), 'run')} requested, {summary.skipped} already in {results}, "
        f"{len(todo)} to run")
    if not todo:
        return summary
    own = executor is None
    ex = make_executor(jobs, backend, address) if executor is None else executor
    t_start = time.perf_counter()
    try:
        with ResultsWriter(results) as writer:
            for rec in ex.map_unordered(execute, todo):
                if "error" in rec:
                    summary.failed.append(rec)
                    log(f"FAILED {rec['optimiser']} {rec['task']} run {rec['run']}: "
                        f"{rec['error']}")
                    continue
                writer.write(rec)
                summary.done += 1
                mark = "feasible" if rec["feasible"] else f"phi {rec['phi']:.4g}"
                log(f"[{summary.done}/{len(todo)}] {rec['optimiser']} {rec['task']} "
                    f"init {rec['init']}{_imax_tag(rec)} run "
                    f"{rec['run']}: score {rec['score']:.6g} ({mark}), {rec['wall_s']:.1f} s, "
                    f"elapsed {time.perf_counter() - t_start:.0f} s")
                task = rec["task"]
                if (bk is not None and rec["feasible"] and rec.get("i_max") is None
                        and rec["f"] < best.get(task, math.inf)):
                    stored = bk.offer(task, files[task], rec["hover_points"], rec["hover_times"],
                                      optimiser=rec["optimiser"], seed=rec["seed"],
                                      budget=rec["budget"], run=rec["run"], command=command)
                    if stored:
                        best[task] = float(rec["f"])
                        summary.best_known_updates.append(task)
                        log(f"  new best-known f on {task}: {rec['f']:.6g} ({rec['optimiser']})")
    finally:
        if own:
            ex.close()
    return summary

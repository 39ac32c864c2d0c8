"""Markdown report of a benchmark folder, like the paper's Table 2, with figures (matplotlib Agg).

Sections: the commands that produced the results, the setup, the penalised-score table (mean +-
std per task, best mean bold, Wilcoxon marks and +/~/- counts against the reference column), a
per-optimiser summary (feasibility, wall time, mean rank), feasibility per task, the results
against the limits (mean f of feasible runs / best-known and / LB), every run's score per task,
one convergence plot per task and each optimiser's best path on four tasks (the figures are
`planner_core.bench.figures`); the I_max study when runs override I_max, and the ablation study
(`planner_core.bench.ablation`) when meta.json holds its entry. Either study can also come from
its own benchmark folder (`study_sections`: `lamde-mission report RESULTS --imax DIR
--ablations DIR`), e.g. a slim copy kept in the repository (`planner_core.bench.store`).
"""

from __future__ import annotations

import math
import os
from collections import defaultdict
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from planner_core.bench._io import read_meta, stored_path, write_text_atomic
from planner_core.bench.records import (
    RESULTS_FILE,
    ReadReport,
    read_records,
    skipped_note,
    skipped_parts,
)
from planner_core.bench.stats import ALPHA, ScoreTable, score_table
from planner_core.defaults import SCORE_FACTOR
from planner_core.textio import printable

__all__ = ["DEFAULT_REFERENCE", "LB_CACHE_FILE", "build_report", "cost_section",
           "figures_folder", "imax_section", "imax_table", "order_optimisers", "format_table",
           "fmt", "study_sections", "suite_folder", "suite_of_results"]

#: the lower bounds a report computed, in the benchmark folder (`build_report`)
LB_CACHE_FILE = "lower_bounds.json"

#: start modes in the report's order, and what each means
INIT_ORDER = ("uniform", "seeded")
INIT_TEXT = {
    "uniform": "The paper's protocol (Sec. 5.1): every optimiser starts from uniform random "
    "points in the box; no sensor-aware seeding.",
    "seeded": "The product's protocol: optimisers that take a start (our DE, CMA-ES's first "
    "point, scipy's DE, L-SRTDE) start from the problem's sensor-aware seeded population.",
}


def _init(record: dict[str, Any]) -> str:
    return str(record.get("init", "seeded"))

#: the column the Wilcoxon marks compare against unless told otherwise
DEFAULT_REFERENCE = "de-adaptive"


def fmt(v: float) -> str:
    """A score for the table: 1 decimal below 1e5, else 3 significant digits in e-notation.

    Args:
        v: the score, or None.

    Returns:
        The text; "-" for None or NaN, "inf" / "-inf" for infinities.
    """
    if v is None or not np.isfinite(v):
        return "-" if v is None or np.isnan(v) else ("inf" if v > 0 else "-inf")
    return f"{v:.1f}" if abs(v) < 1e5 else f"{v:.3e}"


def order_optimisers(present: Sequence[str], reference: str | None) -> list[str]:
    """Reference first, then the registry's order, then any other names alphabetically.

    Args:
        present: the optimiser names present.
        reference: the reference column (put first only when present), or None.

    Returns:
        The names of `present`, ordered.
    """
    from planner_core.bench.baselines import REGISTRY

    known = [o for o in REGISTRY if o in present and o != reference]
    other = sorted(o for o in present if o not in REGISTRY and o != reference)
    return ([reference] if reference in present else []) + known + other


def format_table(table: ScoreTable) -> list[str]:
    """Markdown lines of the score table (cells "mean ± std mark", best bold, counts row).

    Args:
        table: the `ScoreTable` (`stats.score_table`).

    Returns:
        Header, rule, one line per task ("-" for an empty cell), and a "+/~/-" counts row when
        the table has a reference.
    """
    opts = table.optimisers
    lines = ["| Task | " + " | ".join(_col(o, table.reference) for o in opts) + " |",
             "|---|" + "---:|" * len(opts)]
    for t in table.tasks:
        cells = []
        for o in opts:
            c = table.cells[t][o]
            if c.n == 0:
                cells.append("-")
                continue
            body = f"{fmt(c.mean)} ± {fmt(c.std)}"
            body = f"**{body}**" if c.best else body
            cells.append(f"{body} {c.mark}".rstrip())
        lines.append(f"| {t} | " + " | ".join(cells) + " |")
    if table.reference is not None:
        row = []
        for o in opts:
            if o == table.reference:
                row.append("(reference)")
            else:
                p, s, m = table.counts[o]
                row.append(f"{p}/{s}/{m}")
        lines.append("| +/~/- | " + " | ".join(row) + " |")
    return lines


def _col(o: str, reference: str | None) -> str:
    return f"{o} (ref)" if o == reference else o


def _by(records: list[dict[str, Any]]) -> dict[str, dict[str, list[dict[str, Any]]]]:
    out: dict[str, dict[str, list[dict[str, Any]]]] = defaultdict(lambda: defaultdict(list))
    for r in records:
        out[r["task"]][r["optimiser"]].append(r)
    for per in out.values():
        for runs in per.values():
            runs.sort(key=lambda r: int(r["run"]))
    return out


def _rel(path: Path, start: Path) -> str:
    return Path(os.path.relpath(path.resolve(), start.resolve())).as_posix()


# ----------------------------------------------------------------------------- figures


def _runs_per(records: list[dict[str, Any]]) -> list[int]:
    """The distinct numbers of runs per (task, optimiser) in `records`."""
    n: dict[tuple[str, str], int] = defaultdict(int)
    for r in records:
        n[(r["task"], r["optimiser"])] += 1
    return sorted(set(n.values()))


def _spread(tasks: list[str], k: int = 4) -> list[str]:
    if len(tasks) <= k:
        return list(tasks)
    idx = np.unique(np.round(np.linspace(0, len(tasks) - 1, k)).astype(int))
    return [tasks[i] for i in idx]


# ----------------------------------------------------------------------------- the report


def figures_folder(output: str | Path, figures: str | Path | None = None) -> Path:
    """The folder a report's PNGs go to: `figures` when given, else a folder named after the
    report beside it (docs/results/ for docs/results.md).

    Args:
        output: the markdown report's path.
        figures: the folder asked for, or None.

    Returns:
        The folder (not created).
    """
    return Path(figures) if figures is not None else Path(output).with_suffix("")


def build_report(
    results_dir: str | Path,
    output: str | Path,
    *,
    reference: str | None = DEFAULT_REFERENCE,
    suite: str | Path | None = None,
    figures: str | Path | None = None,
    path_tasks: Sequence[str] | None = None,
    limits: bool = True,
    command: str = "",
    alpha: float = ALPHA,
    policy_checkpoint: str | Path | None = None,
    title: str = "Benchmark results",
    imax: str | Path | None = None,
    ablations: str | Path | None = None,
    log: Callable[[str], None] | None = None,
    update_lower_bounds: bool = False,
) -> Path:
    """Write the markdown report of `results_dir` to `output` (figures beside it); return it.

    Each start mode present ("init" of the records; older records without it are seeded) gets
    its own section; runs with an I_max override go to the I_max study section. When meta.json
    holds an ablation entry (`benchmarks/ablations.py`), its reference is the default reference
    and the ablation section follows (`planner_core.bench.ablation`). A hand-written block of a
    report already at `output` is kept (`kept_notes`). Everything that can refuse the report
    does so before a figure is written.

    Args:
        results_dir: the benchmark folder (results.jsonl or results.jsonl.gz, meta.json).
        output: the markdown file to write.
        reference: the Wilcoxon reference column; must be one of the optimisers present when
            given explicitly; the default (`DEFAULT_REFERENCE`), when absent, and None fall
            back to the first optimiser present in `order_optimisers`' order (for the default,
            `log` is told which).
        suite: the suite folder (default: meta.json's, found by `suite_folder` from here, the
            absolute path recorded or the results folder), for the maps, limits and safety
            margins.
        figures: folder for the PNGs (default: a folder named after the report, e.g.
            docs/results/ for docs/results.md).
        path_tasks: tasks of the best-path figure (default: up to four spread over the tasks).
        limits: whether to add the section against LB and best-known.
        command: the command line, shown as "Report produced by".
        alpha: significance level of the rank-sum tests.
        policy_checkpoint: a policy checkpoint folder whose `curve.csv` gives the training
            cost.
        title: the first heading.
        imax: benchmark folder of the I_max study, reported in its own section after the
            protocols (`study_sections`).
        ablations: benchmark folder of the ablation study, likewise.
        log: receives a note (`records.skipped_note`) for each results file read (this
            folder's and the studies') whose lines were not all read: a cut last line, an
            unreadable line, a duplicate run; their runs are left out of the report, which
            says so too; and a line naming the reference fallen back to when the default
            reference has no runs.
        update_lower_bounds: where the limits section stores the lower bounds it computes
            (a map the cache beside the suite lacks, or whose file changed): False (default)
            in `results_dir`/lower_bounds.json (`LB_CACHE_FILE`), read back by the next
            report of the folder, so a report writes nothing beside the suite (a suite in a
            checkout stays clean); True in the cache beside the suite
            (`planner_core.bench.limits.lower_bounds_path`), as `report --update-lower-bounds`.

    Returns:
        `output`.

    Raises:
        ValueError: no results, an explicit reference without results, `output` a folder,
            path tasks not in the results, a policy checkpoint without curve.csv, an
            unreadable results or meta file, or a study folder `study_sections` refuses.
    """
    from planner_core.bench.baselines import REGISTRY

    results_dir = Path(results_dir)
    output = Path(output)
    read = read_records(results_dir / RESULTS_FILE)
    records = read.records
    if not records:
        raise ValueError(f"no results in {results_dir / RESULTS_FILE}")
    _note_skipped(results_dir / RESULTS_FILE, read, log)
    meta = read_meta(results_dir)
    present = sorted({r["optimiser"] for r in records})
    from planner_core.bench.ablation import META_KEY, ablation_section

    ablation = meta.get(META_KEY)
    if ablation and reference == DEFAULT_REFERENCE:
        reference = str(ablation["reference"])
    fell_back = False
    if reference is not None and reference not in present:
        if reference != DEFAULT_REFERENCE:
            raise ValueError(f"reference '{reference}' has no results (have {', '.join(present)})")
        reference, fell_back = None, True
    opts = order_optimisers(present, reference)
    if reference is None:
        reference = opts[0]
        opts = order_optimisers(present, reference)
    if fell_back and log is not None:
        log(f"note: {printable(str(stored_path(results_dir / RESULTS_FILE)))} holds no "
            f"{DEFAULT_REFERENCE} runs: the reference (--reference) is {reference}, the first "
            "optimiser present in the registry's order (`bench --list`)")
    if ablation:  # the variants in the study's order, the reference last (as the paper's table)
        named = [v for v in ablation.get("variants", {}) if v in present and v != reference]
        opts = named + [o for o in opts if o not in named and o != reference] + [reference]
    tasks = sorted({r["task"] for r in records})
    # everything that can refuse the report does so before a figure is written
    if output.is_dir():
        raise ValueError(f"{output}: is a folder; give the markdown file to write")
    unknown = [t for t in path_tasks or () if t not in tasks]
    if unknown:
        raise ValueError(f"path tasks: {', '.join(unknown)} not in the results "
                         f"(have {', '.join(tasks)})")
    if policy_checkpoint is not None and not (Path(policy_checkpoint) / "curve.csv").is_file():
        raise ValueError(f"policy checkpoint {policy_checkpoint}: no curve.csv")
    budgets = sorted({int(r["budget"]) for r in records})
    budget = budgets[-1]
    figures = figures_folder(output, figures)
    shown = Path(suite) if suite is not None else (Path(meta["suite"]) if "suite" in meta
                                                   else None)  # fmt: skip
    # read from where the folder is found (`suite_folder`); named as given or recorded, so that
    # the report's text does not depend on the folder it is made from
    suite_dir = Path(suite) if suite is not None else suite_folder(meta, results_dir)

    L: list[str] = [f"# {title}", ""]
    cmds = [c.get("command", "") for c in meta.get("commands", []) if c.get("command")]
    if cmds:
        L.append("Results produced by:")
        L.append("")
        L += [f"    {c}" for c in dict.fromkeys(cmds)]
        L.append("")
    if command:
        L += ["Report produced by:", "", f"    {command}", ""]
    L += kept_notes(output)
    per_mode: dict[tuple[str, str, str], int] = defaultdict(int)
    for r in records:
        if r.get("i_max") is None:
            per_mode[(r["task"], r["optimiser"], _init(r))] += 1
    runs_per = sorted(set(per_mode.values()))
    L += [
        "## Setup",
        "",
        f"- {len(tasks)} task(s) ({', '.join(tasks)}) from `{shown}`; "
        f"budget {budget:,} evaluations per run (initial population included); "
        + (f"runs per optimiser, task and start mode: {', '.join(map(str, runs_per))}."
           if runs_per else "only I_max study runs (below)."),
        f"- Score = f + {SCORE_FACTOR:g} * phi (lower is better; phi = 0 means feasible), as in "
        "the paper's Table 2. Cells: mean ± std (ddof 0) over runs; best mean per task in bold.",
        f"- Marks: Wilcoxon rank-sum test (`scipy.stats.ranksums`, two-sided, alpha {alpha}) of "
        f"each optimiser against the reference **{reference}**: `+` the reference is "
        "significantly better, `-` significantly worse, `~` no significant difference.",
        *(["- Our DE variants report the raw DE result (no hover-time polish), so the "
           "comparison is on the optimiser alone."]
          if any(_raw_de(o, meta) for o in opts) else []),
        _safety_line(suite_dir, tasks),
        *(["- Wall times exclude compiling: each worker process compiles (or loads from "
           "numba's disk cache) the kernels its optimisers run before its first timed run."]
          if meta.get("wall_excludes_compile") else []),
        "",
        "| Optimiser | What it is |",
        "|---|---|",
    ]
    for o in opts:
        desc = (REGISTRY[o].description if o in REGISTRY else
                meta.get("optimisers", {}).get(o, {}).get("description", "(not in the registry)"))
        L.append(f"| {o} | {desc} |")
    skipped = skipped_parts(read)
    if skipped:
        L += ["", f"Note: skipped in the results file: {', '.join(skipped)}."]
    if len(budgets) > 1:
        L += ["", f"Warning: the results mix budgets {budgets}."]

    maps: dict[str, Any] = {}
    if suite_dir is not None and suite_dir.is_dir():
        from planner_core.bench.limits import suite_task_files
        from planner_core.model.mapio import load_map

        files = suite_task_files(suite_dir)
        maps = {t: load_map(files[t]) for t in tasks if t in files}
    main = [r for r in records if r.get("i_max") is None]
    modes = [m for m in INIT_ORDER if any(_init(r) == m for r in main)]
    for mode in modes:
        recs = [r for r in main if _init(r) == mode]
        L += ["", f"## Protocol: init {mode}", "", INIT_TEXT[mode]]
        L += _protocol_body(recs, opts, reference, alpha, suite_dir, maps, limits, figures,
                            output, path_tasks, budget, mode, suffix="" if len(modes) == 1
                            else f"_{mode}", shown=shown,
                            lb_cache=None if update_lower_bounds
                            else results_dir / LB_CACHE_FILE)
    study = [r for r in records if r.get("i_max") is not None]
    if study:
        L += imax_section(study, figures / "imax_feasible_rate.png", output,
                          reference=reference, alpha=alpha)
    if ablation:
        L += ablation_section(main, ablation, figures, lambda p: _rel(p, output.parent), alpha)
    L += study_sections(output, figures, imax=imax, ablations=ablations, alpha=alpha, log=log,
                        reference=reference)
    L += cost_section(records, policy_checkpoint)
    write_text_atomic(output, "\n".join(L) + "\n")
    return output


#: a hand-written block of a report (e.g. "what this shows") between these two lines is carried
#: over when the report is rebuilt over it, placed after the commands
KEEP_START = "<!-- hand-written: kept when this report is rebuilt -->"
KEEP_END = "<!-- end of the hand-written part -->"


#: the target of our DE run alone (`planner_core.bench.baselines.de.optimise`: no polish)
_RAW_DE = "planner_core.bench.baselines.de:optimise"


def _raw_de(name: str, meta: dict[str, Any]) -> bool:
    """Whether optimiser `name` is one of our DE variants, which report the raw DE result: a
    registry entry or an entry of meta.json's `optimisers` (the ablation variants) whose target
    is `_RAW_DE` (`planner`, `engineering` and the rest polish; a MetaBox agent is not ours)."""
    from planner_core.bench.baselines import REGISTRY

    if name in REGISTRY:
        return REGISTRY[name].target == _RAW_DE
    entry = meta.get("optimisers", {}).get(name, {})
    return isinstance(entry, dict) and entry.get("target") == _RAW_DE


def kept_notes(output: str | Path) -> list[str]:
    """Lines of the hand-written block (KEEP_START ... KEEP_END, markers included) of the
    report already at `output`, with a blank line after; [] when there is none.

    Args:
        output: the report's path.

    Returns:
        The block's lines and a final "" ([] without a file or a block).

    Raises:
        ValueError: naming the file, when it exists but cannot be read as text.
    """
    from planner_core.textio import InputError, printable, read_text

    path = Path(output)
    if not path.is_file():
        return []
    try:
        text = read_text(path)
    except InputError as exc:
        raise ValueError(f"{printable(path)}: {exc}") from None
    i, j = text.find(KEEP_START), text.find(KEEP_END)
    if i < 0 or j < i:
        return []
    return text[i : j + len(KEEP_END)].split("\n") + [""]


def _protocol_body(records: list[dict[str, Any]], opts_all: list[str], reference: str,
                   alpha: float, suite_dir: Path | None, maps: dict[str, Any], limits: bool,
                   figures: Path, output: Path, path_tasks: Sequence[str] | None, budget: int,
                   mode: str, suffix: str, shown: Path | None = None,
                   lb_cache: Path | None = None) -> list[str]:
    """The tables and figures of one protocol (start mode `mode`): score table, per
    optimiser, feasibility, limits, scores per task, convergence, best paths. Figure names
    carry `suffix`; the suite is read from `suite_dir` and named `shown` (default: the
    same); computed lower bounds go to `lb_cache` (None: the cache beside the suite)."""
    tasks = sorted({r["task"] for r in records})
    present = {r["optimiser"] for r in records}
    opts = [o for o in opts_all if o in present]
    if reference not in present:
        reference = opts[0]
    by = _by(records)
    scores = {t: {o: [r["score"] for r in by[t].get(o, [])] for o in opts} for t in tasks}
    table = score_table(scores, tasks, opts, reference, alpha)
    L: list[str] = []
    L += ["", "### Penalised score f + 10 phi", ""] + format_table(table)

    # ---- per optimiser summary
    ranks = _mean_ranks(table)
    L += ["", "### Per optimiser", "",
          "| Optimiser | runs | feasible runs | mean wall time (s) | mean evaluations "
          "| mean rank | +/~/- vs ref |",
          "|---|---:|---:|---:|---:|---:|---:|"]
    for o in opts:
        rs = [r for t in tasks for r in by[t].get(o, [])]
        feas = sum(r["feasible"] for r in rs)
        wall = np.mean([r["wall_s"] for r in rs])
        ev = np.mean([r["evaluations"] for r in rs])
        cnt = "(reference)" if o == reference else "/".join(map(str, table.counts[o]))
        L.append(f"| {o} | {len(rs)} | {feas} ({100 * feas / len(rs):.0f} %) | {wall:.2f} "
                 f"| {ev:,.0f} | {ranks[o]:.2f} | {cnt} |")

    L += ["", "### Feasibility rate per task (runs with phi = 0)", "",
          "| Task | " + " | ".join(opts) + " |", "|---|" + "---:|" * len(opts)]
    for t in tasks:
        row = []
        for o in opts:
            rs = by[t].get(o, [])
            row.append(f"{100 * np.mean([r['feasible'] for r in rs]):.0f} %" if rs else "-")
        L.append(f"| {t} | " + " | ".join(row) + " |")

    if limits:
        L += _limits_section(tasks, opts, by, suite_dir, suite_dir if shown is None else shown,
                             lb_cache)

    # ---- figures
    from planner_core.bench import figures as F

    runs = _runs_per(records)
    protocol = F.protocol_text(mode, budget, runs)
    grouped = {t: {o: [(float(r["score"]), bool(r["feasible"])) for r in by[t].get(o, [])]
                   for o in opts} for t in tasks}
    fig = F.scores_figure(tasks, grouped, opts, protocol=protocol,
                          what=f"Final score of every run per task: {len(opts)} optimisers")
    p = F.save(fig, figures / f"scores{suffix}.png")
    L += ["", "### Scores per task", "",
          "Every run's final f + 10 phi (dot: feasible, cross: infeasible), with the median "
          "(bar) and the 25-75 % box; log scale when the scores span a decade.", "",
          f"![scores per task]({_rel(p, output.parent)})"]
    L += ["", "### Convergence", "",
          "Median incumbent score (25-75 % band) against evaluations, each run's final score "
          "right of the budget line (dot: feasible, cross: infeasible). For our DE and "
          "random search the incumbent is the Deb-best; for CMA-ES and scipy's DE the best "
          "penalised score seen.", ""]
    for t in tasks:
        fig = F.convergence_figure(t, by[t], opts, budget, init=mode)
        p = F.save(fig, figures / f"convergence_{t}{suffix}.png")
        L.append(f"![{t} convergence]({_rel(p, output.parent)})")
    ptasks = list(path_tasks) if path_tasks else _spread([t for t in tasks if t in maps])
    ptasks = [t for t in ptasks if t in maps]
    slim = [t for t in ptasks if any("hover_points" not in r for o in opts
                                     for r in by[t].get(o, []))]  # fmt: skip
    if slim:  # slim copies (benchmarks/store_runs.py) keep no plans to draw
        ptasks = []
        L += ["", "### Best paths", "",
              "Not drawn: these records are slim copies without the runs' hover points "
              "(`benchmarks/store_runs.py`); `report` the benchmark's own folder to draw them."]
    if ptasks:
        best = {t: {o: min(by[t][o], key=lambda r: r["score"]) for o in opts if by[t].get(o)}
                for t in ptasks}
        known = _known_entries(suite_dir, {t: maps[t] for t in ptasks})
        fig = F.paths_figure(ptasks, maps, best, opts, known=known, protocol=protocol,
                             runs=max(runs) if len(runs) == 1 else None)
        p = F.save(fig, figures / f"best_paths{suffix}.png")
        L += ["", "### Best paths", "",
              f"Each optimiser's best run (lowest score over its runs) on {', '.join(ptasks)}, "
              "one map per optimiser: solid = feasible, dotted = infeasible; wide grey = the "
              "best-known plan; obstacles grey, no-fly zones red; sensors green triangles; "
              "start o, end square.", "",
              f"![best paths]({_rel(p, output.parent)})"]
    return L


def imax_table(records: list[dict[str, Any]]) -> dict[str, dict[int, tuple[float, float, int]]]:
    """I_max study: the last population's feasible rate per optimiser and I_max (records
    without a rate or an I_max are skipped).

    Args:
        records: run records.

    Returns:
        optimiser -> I_max (ascending) -> (mean, std (ddof 0) over runs and tasks, n).
    """
    acc: dict[str, dict[int, list[float]]] = defaultdict(lambda: defaultdict(list))
    for r in records:
        rate = r.get("last_feasible_rate")
        if r.get("i_max") is None or rate is None:
            continue
        acc[r["optimiser"]][int(r["i_max"])].append(float(rate))
    return {o: {k: (float(np.mean(v)), float(np.std(v)), len(v)) for k, v in sorted(d.items())}
            for o, d in acc.items()}


def imax_section(records: list[dict[str, Any]], path: Path, output: Path,
                 source: list[str] | None = None, reference: str | None = None,
                 alpha: float = ALPHA) -> list[str]:
    """Markdown (table + figure) of the I_max study (paper Fig. 4): the last population's
    feasible rate against I_max, per optimiser and start mode, then the final scores at each
    I_max summed up over the tasks (best means, Wilcoxon +/~/- against `reference`).

    Args:
        records: the study's run records (each with an "i_max").
        path: the PNG to write the figure to.
        output: the report's path (the figure is linked relative to its folder).
        source: lines saying where the runs are, after the first paragraph.
        reference: the Wilcoxon reference (default, or when absent: the first optimiser in
            the report's order).
        alpha: significance level of the rank-sum tests.

    Returns:
        The section's Markdown lines.
    """
    L = ["", "## I_max study (paper Fig. 4)", "",
         "Feasible rate of the last population (share with phi = 0) against I_max "
         "(`uav.max_hover_points` overridden on every map): mean ± std over tasks and runs. "
         "The paper: LAMDE-F (fixed length) at 0 from I_max >= 70, LAMDE above 0.6 at 100."]
    if source:
        L += ["", *source]
    tasks = sorted({r["task"] for r in records})
    runs = sorted({int(r["run"]) for r in records})
    budgets = sorted({int(r["budget"]) for r in records})
    L += ["", f"{len(tasks)} task(s) ({', '.join(tasks)}), {len(runs)} run(s) each, budget "
          f"{', '.join(f'{b:,}' for b in budgets)}."]
    from planner_core.bench import figures as F

    tables: dict[str, dict[str, dict[int, tuple[float, float, int]]]] = {}
    for mode in INIT_ORDER:
        recs = [r for r in records if _init(r) == mode]
        tab = imax_table(recs)
        if not tab:
            continue
        tables[mode] = tab
        ks = sorted({k for d in tab.values() for k in d})
        L += ["", f"Start mode {mode}:", "", "| Optimiser | " + " | ".join(
            f"I_max {k}" for k in ks) + " |", "|---|" + "---:|" * len(ks)]
        for o, d in tab.items():
            L.append(f"| {o} | " + " | ".join(
                f"{d[k][0]:.2f} ± {d[k][1]:.2f} (n {d[k][2]})" if k in d else "-" for k in ks)
                + " |")
    fig = F.imax_figure(tables, n_tasks=len(tasks), runs=len(runs),
                        budget=budgets[-1] if len(budgets) == 1 else None)
    p = F.save(fig, path)
    L += ["", f"![I_max study]({_rel(p, output.parent)})"]
    opts = order_optimisers(sorted({r["optimiser"] for r in records}), reference)
    ref = reference if reference in opts else opts[0]
    L += ["", f"Final score f + 10 phi at each I_max, over the {len(tasks)} task(s): on how "
          "many tasks each optimiser has the best mean, and the per-task Wilcoxon rank-sum "
          f"counts (two-sided, alpha {alpha}) against **{ref}** (`+` {ref} significantly "
          "better, `~` no significant difference, `-` worse)."]
    for mode in INIT_ORDER:
        recs = [r for r in records if _init(r) == mode]
        if not recs:
            continue
        ks = sorted({int(r["i_max"]) for r in recs})
        cols: dict[int, ScoreTable] = {}
        for k in ks:
            by = _by([r for r in recs if int(r["i_max"]) == k])
            scores = {t: {o: [r["score"] for r in by[t].get(o, [])] for o in opts}
                      for t in by}
            cols[k] = score_table(scores, sorted(by), opts, ref, alpha)
        L += ["", f"Start mode {mode}:", "", "| Optimiser | " + " | ".join(
            f"I_max {k}" for k in ks) + " |", "|---|" + "---:|" * len(ks)]
        for o in opts:
            cells = []
            for k in ks:
                tab = cols[k]
                best = f"best on {sum(tab.cells[t][o].best for t in tab.tasks)}/{len(tab.tasks)}"
                cells.append(best if o == ref else
                             f"{best}, +/~/- {'/'.join(map(str, tab.counts[o]))}")
            L.append(f"| {_col(o, ref)} | " + " | ".join(cells) + " |")
    return L


def _study_source(folder: Path, meta: dict[str, Any], left_out: list[int],
                  kept: list[dict[str, Any]]) -> list[str]:
    """Where a study's runs are, the commands that made them, and what an unfinished run left
    out."""
    runs = sorted({int(r["run"]) for r in kept})
    L = [f"Runs: `{folder.as_posix()}`"
         + (f" (slim copy of `{meta['stored']['from']}`, `benchmarks/store_runs.py`)"
            if "stored" in meta else "") + ", produced by:", ""]
    cmds = [c.get("command", "") for c in meta.get("commands", []) if c.get("command")]
    driver = (meta.get("ablation") or {}).get("driver")
    L += [f"    {c}" for c in dict.fromkeys([driver] if driver else cmds)]
    if left_out:
        L += ["", f"The benchmark had not finished: runs {', '.join(map(str, left_out))} "
              "exist for some cells only and are left out, so every cell (optimiser, task, "
              f"start mode, I_max) counts the same {len(runs)} run(s) (the runner runs "
              "run-major: every cell's run r before any cell's run r + 1)."]
    return L


def _note_skipped(path: Path, read: ReadReport, log: Callable[[str], None] | None) -> None:
    """`log` the note on the lines a read of results file `path` left out, if any (the
    report's tables are over the runs read)."""
    note = skipped_note(path, read)
    if note is not None and log is not None:
        log(f"{note}; their runs are not in the report")


def _study_records(folder: Path, what: str, log: Callable[[str], None] | None = None
                   ) -> tuple[list[dict[str, Any]], dict[str, Any], list[int]]:
    from planner_core.bench.records import complete_runs

    read = read_records(folder / RESULTS_FILE)
    recs = read.records
    if not recs:
        raise ValueError(f"--{what} {folder}: no results in {folder / RESULTS_FILE}")
    _note_skipped(folder / RESULTS_FILE, read, log)
    kept, left_out = complete_runs(recs)
    if not kept:
        raise ValueError(f"--{what} {folder}: no run index is finished in every cell yet")
    return kept, read_meta(folder), left_out


def study_sections(output: str | Path, figures: str | Path, *, imax: str | Path | None = None,
                   ablations: str | Path | None = None, alpha: float = ALPHA,
                   reference: str | None = None,
                   log: Callable[[str], None] | None = None) -> list[str]:
    """Markdown of the ablation study and the I_max study, each from its own benchmark folder
    (`benchmarks/ablations.py --out DIR` with its meta.json ablation entry; `lamde-mission
    bench --i-max ... --out DIR`), or a slim copy of it (`benchmarks/store_runs.py`). Only the
    run indices finished in every cell are used (`records.complete_runs`), so an unfinished
    study is reported on equal counts and says what it left out.

    Args:
        output: the report's path (figures are linked relative to its folder).
        figures: folder for the PNGs.
        imax: the I_max study's benchmark folder, or None.
        ablations: the ablation study's benchmark folder, or None.
        alpha: significance level of the rank-sum tests.
        reference: the I_max study's Wilcoxon reference (the ablations use their own, LAMDE).
        log: receives a note for a study's results file whose lines were not all read
            (`build_report`'s).

    Returns:
        The sections' Markdown lines (ablations first); [] when neither folder is given.

    Raises:
        ValueError: a folder without results or without a run index finished in every cell,
            (ablations) without the ablation entry, or (imax) without runs overriding I_max.
    """
    output, figures = Path(output), Path(figures)
    L: list[str] = []
    if ablations is not None:
        from planner_core.bench.ablation import META_KEY, ablation_section

        folder = Path(ablations)
        recs, meta, left_out = _study_records(folder, "ablations", log)
        entry = meta.get(META_KEY)
        if not entry:
            raise ValueError(f"--ablations {folder}: meta.json has no '{META_KEY}' entry "
                             "(benchmarks/ablations.py writes it)")
        main = [r for r in recs if r.get("i_max") is None]
        reference = str(entry["reference"])
        present = {r["optimiser"] for r in main}
        named = [v for v in entry.get("variants", {}) if v in present and v != reference]
        opts = named + sorted(present - set(named) - {reference}) + [reference]
        scores: dict[str, list[str]] = {}
        for mode in INIT_ORDER:
            rs = [r for r in main if _init(r) == mode]
            if rs:
                scores[mode] = _ablation_scores(rs, [o for o in opts if o in
                                                     {r["optimiser"] for r in rs}],
                                                reference, alpha, mode)
        L += ablation_section(main, entry, figures, lambda p: _rel(p, output.parent), alpha,
                              source=_study_source(folder, meta, left_out, main),
                              scores=scores)
    if imax is not None:
        folder = Path(imax)
        recs, meta, left_out = _study_records(folder, "imax", log)
        study = [r for r in recs if r.get("i_max") is not None]
        if not study:
            raise ValueError(f"--imax {folder}: no run overrides I_max (bench --i-max)")
        L += imax_section(study, figures / "imax_feasible_rate.png", output,
                          source=_study_source(folder, meta, left_out, study),
                          reference=reference, alpha=alpha)
    return L


def _ablation_scores(records: list[dict[str, Any]], opts: list[str], reference: str,
                     alpha: float, mode: str) -> list[str]:
    """The ablation's per-task score table (paper Table 3) of one start mode, and per variant
    its feasible runs."""
    tasks = sorted({r["task"] for r in records})
    by = _by(records)
    scores = {t: {o: [r["score"] for r in by[t].get(o, [])] for o in opts} for t in tasks}
    table = score_table(scores, tasks, opts, reference, alpha)
    L = ["", f"### Penalised score f + 10 phi per task, init {mode} (paper Table 3)", "",
         f"Mean ± std over runs, best mean bold; marks: Wilcoxon rank-sum (two-sided, alpha "
         f"{alpha}) against **{reference}** (`+` {reference} significantly better, `-` "
         "worse, `~` no significant difference).", ""]
    L += format_table(table)
    L += ["", "| Variant | runs | feasible runs | best mean on | mean wall time (s) |",
          "|---|---:|---:|---:|---:|"]
    for o in opts:
        rs = [r for t in tasks for r in by[t].get(o, [])]
        feas = sum(bool(r["feasible"]) for r in rs)
        best = sum(table.cells[t][o].best for t in tasks)
        L.append(f"| {o} | {len(rs)} | {feas} ({100 * feas / len(rs):.0f} %) | "
                 f"{best}/{len(tasks)} | {np.mean([r['wall_s'] for r in rs]):.2f} |")
    return L


def _policy_names(records: list[dict[str, Any]]) -> list[str]:
    return sorted({r["optimiser"] for r in records if "lamde" in r["optimiser"]})


def cost_section(records: list[dict[str, Any]], checkpoint: str | Path | None) -> list[str]:
    """Training cost (from the checkpoint's `curve.csv`, column `seconds` per epoch, and its
    warm start's `imitation.csv` when there is one) and inference cost per plan (mean
    optimiser wall time of the policy's runs, those with "lamde" in their name, against our
    hand-made adaptive DE on the same runs).

    Args:
        records: run records.
        checkpoint: the policy checkpoint folder, or None.

    Returns:
        The section's Markdown lines; empty when there is neither a checkpoint nor a policy
        run.

    Raises:
        ValueError: the checkpoint has no curve.csv, or a CSV cannot be read.
    """
    pol = _policy_names(records)
    if checkpoint is None and not pol:
        return []
    L = ["", "## Cost of the learned policy", ""]
    if checkpoint is not None:
        from planner_core.bench._io import read_csv_column

        curve = Path(checkpoint) / "curve.csv"
        if not curve.exists():
            raise ValueError(f"policy checkpoint {checkpoint}: no curve.csv")
        rows = read_csv_column(curve, "seconds", ("episodes",))
        secs = sum(r["seconds"] for r in rows)
        eps = sum(int(r.get("episodes", 0)) for r in rows)
        L += [f"- Training ({checkpoint}): {len(rows)} epoch(s), {eps} episode(s), "
              f"{secs:,.0f} s wall ({secs / 60:.1f} min) as recorded in `curve.csv`."]
        warm = Path(checkpoint) / "imitation.csv"  # the behaviour-cloning warm start, if any
        if warm.exists():
            wrows = read_csv_column(warm, "seconds")
            wsecs = sum(r["seconds"] for r in wrows)
            L += [f"- Warm start ({checkpoint}): {len(wrows)} imitation pass(es), "
                  f"{wsecs:,.0f} s wall ({wsecs / 60:.1f} min) as recorded in `imitation.csv`."]
    for ref in [*pol, "de-adaptive"]:  # each policy's runs, then the hand-made DE's once
        rs = [r for r in records if r["optimiser"] == ref and r.get("i_max") is None]
        if rs and pol:
            L.append(f"- Inference per plan, {ref}: mean optimiser wall time "
                     f"{np.mean([r['wall_s'] for r in rs]):.2f} s over {len(rs)} run(s) "
                     f"(budget {int(rs[0]['budget']):,}).")
    return L


def suite_folder(meta: dict[str, Any], results_dir: str | Path) -> Path | None:
    """The suite folder of a benchmark, as recorded in its meta.json, found from here.

    `bench` records the suite as given ("suite", often relative to the folder it ran in) and,
    since 2026-12-06, its absolute path ("suite_absolute"); `report` may run elsewhere. Tried
    in order: the recorded path relative to the current folder, the absolute one, then the
    recorded path relative to the results folder; the first that is a folder wins.

    Args:
        meta: the benchmark's meta.json (`read_meta`).
        results_dir: the benchmark folder.

    Returns:
        The folder found; when none is, the recorded path as given (the caller says it is not
        found); None when meta.json records no suite.
    """
    if "suite" not in meta:
        return None
    given = Path(meta["suite"])
    tries = [given]
    if meta.get("suite_absolute"):
        tries.append(Path(meta["suite_absolute"]))
    if not given.is_absolute():
        tries.append(Path(results_dir) / given)
    return next((p for p in tries if p.is_dir()), given)


def suite_of_results(results: str | Path) -> Path | None:
    """The suite folder a results file's runs were made on: its folder's meta.json, found from
    here (`suite_folder`); for the analysis scripts (`benchmarks/search_table.py`,
    `benchmarks/compare_runs.py`), which take a results file rather than its folder.

    Args:
        results: a `results.jsonl` (or `.jsonl.gz`, or a copy under another name) of `bench`.

    Returns:
        The suite folder when a meta.json beside the file records one that is a folder here;
        None otherwise (no meta.json, no suite recorded, or the folder not found).

    Raises:
        ValueError: an unreadable or malformed meta.json (`read_meta`, naming the file).
    """
    folder = Path(results).parent
    meta = read_meta(folder)
    found = suite_folder(meta, folder)
    return found if found is not None and found.is_dir() else None


def _known_entries(suite_dir: Path | None, maps: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """Best-known entries of these tasks that match the current map files."""
    if suite_dir is None or not suite_dir.is_dir():
        return {}
    from planner_core.bench.limits import BestKnown, best_known_path, suite_task_files

    files = {t: p for t, p in suite_task_files(suite_dir).items() if t in maps}
    bk = BestKnown(best_known_path(suite_dir))
    current = bk.f_values(files)
    return {t: e for t, e in bk.load().items() if t in current}


def _mean_ranks(table: ScoreTable) -> dict[str, float]:
    from scipy.stats import rankdata

    acc: dict[str, list[float]] = defaultdict(list)
    for t in table.tasks:
        present = [o for o in table.optimisers if table.cells[t][o].n > 0]
        if not present:
            continue
        r = rankdata([table.cells[t][o].mean for o in present])
        for o, v in zip(present, r, strict=True):
            acc[o].append(float(v))
    return {o: float(np.mean(acc[o])) if acc[o] else math.nan for o in table.optimisers}


def _safety_line(suite_dir: Path | None, tasks: Sequence[str]) -> str:
    """What the task files say about safety margins (the suite's: zero, the paper's model)."""
    from planner_core.bench.limits import suite_task_files
    from planner_core.model.mapio import MapError, load_map

    if suite_dir is None or not Path(suite_dir).is_dir():
        return "- Safety margins: unknown (the suite folder is not here to read them from)."
    files = suite_task_files(suite_dir)
    margins = {}
    for t in tasks:
        if t in files:
            try:
                sf = load_map(files[t]).spec.safety
            except MapError:
                continue
            margins[t] = (sf.clearance, sf.data_margin)
    if margins and all(v == (0.0, 0.0) for v in margins.values()):
        return ("- Safety margins: none. Every task file says `\"safety\": {\"clearance\": 0, "
                "\"data_margin\": 0}`: the paper's model exactly as it stands.")
    other = ", ".join(f"{t} clearance {c:g} m / data margin {100 * q:g} %"
                      for t, (c, q) in margins.items() if (c, q) != (0.0, 0.0))
    return f"- Safety margins (planned on the inflated map): {other}."


def _limits_section(tasks: list[str], opts: list[str], by: Any,
                    suite_dir: Path | None, shown: Path | None,
                    lb_cache: Path | None = None) -> list[str]:
    """The section against LB and best-known, read from `suite_dir`, which it names `shown`;
    lower bounds read from the cache beside the suite and `lb_cache`, computed ones stored in
    `lb_cache` (None: in the cache beside the suite)."""
    from planner_core.bench.limits import (
        BestKnown,
        best_known_path,
        lower_bounds,
        lower_bounds_path,
    )

    if suite_dir is None or not suite_dir.is_dir():
        return ["", "### Against the limits", "", f"(suite folder {shown} not found)"]
    from planner_core.bench.limits import suite_task_files

    files = {t: p for t, p in suite_task_files(suite_dir).items() if t in tasks}
    lbs = lower_bounds(suite_dir, list(files), cache=lb_cache,
                       also_read=() if lb_cache is None else (lower_bounds_path(suite_dir),))
    bk_all = BestKnown(best_known_path(suite_dir))
    bk_f = bk_all.f_values(files)
    bk_entries = bk_all.load()
    L = ["", "### Against the limits", "",
         "LB: `planner_core.model.bounds` (alpha * flight time of the straight line start -> end + "
         "(1 - alpha) * the LP minimum hover time over 25 m cells, ignoring C3, C5 and flight); "
         f"best-known: `{best_known_path(shown or suite_dir)}` (the best feasible f found by any "
         "run so far; initially the map's witness). Ratios: mean f over an optimiser's feasible "
         "runs divided by best-known (1 = as good as the best known) and by LB "
         "(both >= 1; \"-\" = no feasible run).", "", "Mean feasible f / best-known:", "",
         "| Task | LB | best-known f | found by | " + " | ".join(opts) + " |",
         "|---|---:|---:|---|" + "---:|" * len(opts)]
    ratio_lb: list[str] = []
    for t in tasks:
        lb = lbs.get(t, {}).get("lb", math.nan)
        bk = bk_f.get(t, math.nan)
        src = bk_entries.get(t, {}).get("optimiser", "-") if t in bk_f else "-"
        cells, cells_lb = [], []
        for o in opts:
            feas = [r["f"] for r in by[t].get(o, []) if r["feasible"]]
            if not feas:
                cells.append("-")
                cells_lb.append("-")
                continue
            mf = float(np.mean(feas))
            cells.append(f"{mf / bk:.3f}" if np.isfinite(bk) and bk > 0 else "-")
            cells_lb.append(f"{mf / lb:.3f}" if np.isfinite(lb) and lb > 0 else "-")
        L.append(f"| {t} | {fmt(lb)} | {fmt(bk)} | {src} | " + " | ".join(cells) + " |")
        ratio_lb.append(f"| {t} | " + " | ".join(cells_lb) + " |")
    L += ["", "Mean feasible f / LB:", "",
          "| Task | " + " | ".join(opts) + " |", "|---|" + "---:|" * len(opts)] + ratio_lb
    return L

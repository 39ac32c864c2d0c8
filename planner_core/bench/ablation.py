"""The ablation study's own numbers (paper Sec. 5.3, Table 3 and Fig. 3): normalised performance.

Normalised performance of one run (the paper's footnote): the final penalised score divided by
the initial one, ``(f + 10 phi)`` of the incumbent at the end over that of the incumbent after
the first population (the first entry of the run's convergence trace). Lower is better; 1 means
the run never improved on its first population. Per variant it is aggregated over every task and
run (16 tasks x R runs in the paper's protocol): mean ± std, median, and a two-sided Wilcoxon
rank-sum test of the pooled values against the reference variant (LAMDE).

``benchmarks/ablations.py`` writes a ``"ablation"`` entry into the benchmark folder's
``meta.json`` (:data:`META_KEY`): the reference variant, the variants in order and, per variant,
how it was trained (``description``, ``trainset``, ``checkpoint``). ``lamde-mission report``
adds :func:`ablation_section` whenever that entry is present.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from planner_core.bench.records import key_of
from planner_core.bench.stats import ALPHA, wilcoxon_mark
from planner_core.defaults import INIT_MODES
from planner_core.model.formulas import penalised_score

__all__ = ["META_KEY", "ablation_section", "normalised", "normalised_table", "training_seconds"]

#: the key of the ablation entry in a benchmark folder's meta.json
META_KEY = "ablation"


def normalised(record: dict[str, Any]) -> float:
    """Normalised performance of one run (paper Sec. 5.3, footnote to Fig. 3): final / initial
    penalised score.

    Args:
        record: a run record with "score" and "history" (its first "best_f", "best_phi" entry
            is the incumbent after the first population).

    Returns:
        score / (f + 10 phi) of the first trace entry; NaN when that initial score is not a
        positive finite number, or the record has no trace.
    """
    h = record.get("history") or {}
    if not h.get("best_f"):
        return math.nan
    first = float(penalised_score(float(h["best_f"][0]), float(h["best_phi"][0])))
    if not (math.isfinite(first) and first > 0):
        return math.nan
    return float(record["score"]) / first


def normalised_table(records: list[dict[str, Any]], variants: list[str], reference: str,
                     alpha: float = ALPHA) -> dict[str, dict[str, Any]]:
    """Per variant: the normalised performance over all its runs and its Wilcoxon mark against
    `reference`.

    Args:
        records: run records (each with "optimiser"); runs whose normalised value is not
            finite are dropped.
        variants: the variants (optimiser names), in the table's order.
        reference: the reference variant.
        alpha: significance level of the two-sided rank-sum test.

    Returns:
        {variant: {"n", "mean", "std" (ddof 0), "median", "mark", "values" ((n,) array)}} in
        `variants`' order, variants without runs left out; "mark" is "" for the reference
        itself, "+" the reference is significantly better (i.e. lower), "-" worse, "~" no
        difference.
    """
    acc: dict[str, list[float]] = defaultdict(list)
    for r in records:
        v = normalised(r)
        if math.isfinite(v):
            acc[r["optimiser"]].append(v)
    ref = acc.get(reference, [])
    out = {}
    for o in variants:
        vals = np.asarray(acc.get(o, []), dtype=float)
        if vals.size == 0:
            continue
        out[o] = {"n": int(vals.size), "mean": float(vals.mean()), "std": float(vals.std()),
                  "median": float(np.median(vals)),
                  "mark": "" if o == reference else wilcoxon_mark(ref, vals, alpha),
                  "values": vals}
    return out


def training_seconds(checkpoint: str | Path) -> tuple[int, float] | None:
    """Training cost recorded in a checkpoint folder's curve.csv.

    Args:
        checkpoint: the policy checkpoint folder.

    Returns:
        (epochs, wall seconds): curve.csv's rows and the sum of its "seconds" column; None
        without curve.csv.

    Raises:
        ValueError: an unreadable curve.csv (`read_csv_column`).
    """
    from planner_core.bench._io import read_csv_column

    curve = Path(checkpoint) / "curve.csv"
    if not curve.exists():
        return None
    rows = read_csv_column(curve, "seconds")
    return len(rows), sum(r["seconds"] for r in rows)


def ablation_section(records: list[dict[str, Any]], entry: dict[str, Any], figures: Path,
                     link: Callable[[Path], str], alpha: float = ALPHA, *,
                     source: list[str] | None = None,
                     scores: dict[str, list[str]] | None = None) -> list[str]:
    """Markdown of the ablation study: how each variant was trained, then per start mode the
    normalised-performance table (+ Wilcoxon against the reference) and its box-plot figure
    (paper Fig. 3). The per-task score table with +/~/- counts (paper Table 3) is the
    report's protocol section, whose reference column is the ablation's reference; or, when
    the study is a section of another report (`lamde-mission report --ablations DIR`),
    `scores[mode]`.

    Args:
        records: the study's run records (those with an I_max are left out of the tables).
        entry: meta.json's ablation entry: "reference", "variants" ({name: {"description",
            "checkpoint", ...}}).
        figures: folder the PNGs are written to.
        link: maps a written PNG's path to the link text used in the Markdown.
        alpha: significance level of the rank-sum test.
        source: lines saying where the runs are, after the section's first paragraph.
        scores: per start mode, the per-task score table's lines, placed before that mode's
            normalised performance.

    Returns:
        The section's Markdown lines.

    Raises:
        ValueError: a variant's curve.csv is unreadable (`training_seconds`).
    """
    from planner_core.bench import figures as F

    reference = str(entry["reference"])
    variants_info: dict[str, Any] = entry.get("variants", {})
    present = {r["optimiser"] for r in records}
    trained = [v for v in variants_info if v in present]
    order = trained + sorted(present - set(trained))  # then baselines run alongside, if any
    L = ["", "## Ablations (paper Sec. 5.3, Table 3 and Fig. 3)", "",
         "Every variant is the same policy network trained with the same PPO settings and "
         "budget; they differ only in the training problems or the encoding. The per-task "
         "score table with +/~/- against "
         f"**{reference}** is "
         + ("below, per start mode" if scores is not None else "the protocol section above")
         + " (the paper's Table 3). Normalised "
         "performance per run = final / initial penalised score (the incumbent after the "
         "first population; lower is better), aggregated over every task and run (the paper's "
         "footnote to Fig. 3).", ""]
    if source:
        L += [*source, ""]
    L += ["| Variant | Training | Training cost |", "|---|---|---:|"]
    for v in trained:
        info = variants_info[v]
        cost = "-"
        if info.get("checkpoint"):
            ts = training_seconds(info["checkpoint"])
            if ts is not None:
                cost = f"{ts[0]} epoch(s), {ts[1]:,.0f} s"
        L.append(f"| {v} | {info.get('description', '-')} | {cost} |")
    for mode in sorted(INIT_MODES, key=lambda m: m != "uniform"):  # the paper's protocol first
        recs = [r for r in records if key_of(r).init == mode and r.get("i_max") is None]
        if not recs:
            continue
        table = normalised_table(recs, order, reference, alpha)
        tasks = sorted({r["task"] for r in recs})
        runs = sorted({int(r["run"]) for r in recs})
        if scores is not None and mode in scores:
            L += scores[mode]
        L += ["", f"### Normalised performance, init {mode}", "",
              f"{len(tasks)} task(s) x {len(runs)} run(s) per variant. Mark: Wilcoxon "
              f"rank-sum (two-sided, alpha {alpha}) of the pooled values against "
              f"{reference}: `+` {reference} significantly better, `-` worse, `~` no "
              "significant difference.", "",
              "| Variant | runs | mean ± std | median | vs ref |", "|---|---:|---:|---:|:---:|"]
        for o, c in table.items():
            mark = "(reference)" if o == reference else c["mark"]
            L.append(f"| {o} | {c['n']} | {c['mean']:.4f} ± {c['std']:.4f} | "
                     f"{c['median']:.4f} | {mark} |")
        if table:
            budgets = sorted({int(r["budget"]) for r in recs})
            protocol = F.protocol_text(mode, budgets[-1] if len(budgets) == 1 else None,
                                       len(runs), per=f"variant and task, {len(tasks)} tasks")
            fig = F.ablation_figure({o: c["values"] for o, c in table.items()}, protocol)
            p = F.save(fig, figures / f"ablation_normalised_{mode}.png")
            L += ["", f"![normalised performance, init {mode}]({link(p)})"]
    return L

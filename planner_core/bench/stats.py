"""The paper's Table 2 statistics: mean +- std per cell and Wilcoxon rank-sum marks.

Marks compare each optimiser's scores on a task with the reference optimiser's (two-sided
`scipy.stats.ranksums`, alpha 0.05; lower scores are better): "+" the reference is significantly
better, "-" significantly worse, "~" no significant difference.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["ALPHA", "Cell", "ScoreTable", "wilcoxon_mark", "score_table"]

#: significance level of the rank-sum test
ALPHA = 0.05


def wilcoxon_mark(reference: Sequence[float], other: Sequence[float], alpha: float = ALPHA) -> str:
    """"+" / "-" / "~": is `reference` significantly better / worse than / like `other`?

    Two-sided Wilcoxon rank-sum test (`scipy.stats.ranksums`); lower scores are better.

    Args:
        reference: the reference optimiser's scores.
        other: the other optimiser's scores.
        alpha: significance level.

    Returns:
        "+", "-" or "~" ("~" also for a non-finite p); "" when either side is empty.
    """
    from scipy.stats import ranksums

    ref = np.asarray(reference, dtype=float)
    oth = np.asarray(other, dtype=float)
    if ref.size == 0 or oth.size == 0:
        return ""
    stat, p = ranksums(oth, ref)
    if not np.isfinite(p) or p >= alpha:
        return "~"
    return "+" if stat > 0 else "-"  # stat > 0: `other` ranks higher (worse)


@dataclass(frozen=True)
class Cell:
    """One task x optimiser: the scores' mean, std (ddof 0, as the paper), count, mark, best."""

    mean: float
    std: float
    n: int
    mark: str  # "" for the reference column or an empty cell
    best: bool  # lowest mean on this task


@dataclass(frozen=True)
class ScoreTable:
    """Cells by task and optimiser, and (+, ~, -) counts per optimiser against the reference."""

    tasks: list[str]
    optimisers: list[str]
    reference: str | None
    cells: dict[str, dict[str, Cell]]
    counts: dict[str, tuple[int, int, int]]


def score_table(
    scores: Mapping[str, Mapping[str, Sequence[float]]],
    tasks: Sequence[str],
    optimisers: Sequence[str],
    reference: str | None,
    alpha: float = ALPHA,
) -> ScoreTable:
    """Build the table (paper Table 2) from per-run scores.

    Args:
        scores: scores[task][optimiser] = per-run scores (missing = empty cell).
        tasks: the table's rows, in order.
        optimisers: the table's columns, in order.
        reference: the optimiser the others are marked against; None for no marks.
        alpha: significance level of the rank-sum test.

    Returns:
        The `ScoreTable`: a `Cell` per task and optimiser (empty: NaN mean and std, n 0) and the
        (+, ~, -) counts per optimiser.
    """
    cells: dict[str, dict[str, Cell]] = {}
    counts = {o: [0, 0, 0] for o in optimisers}
    for t in tasks:
        row = scores.get(t, {})
        means = {o: float(np.mean(row[o])) for o in optimisers if len(row.get(o, ())) > 0}
        low = min(means.values()) if means else None
        ref = row.get(reference, ()) if reference is not None else ()
        cells[t] = {}
        for o in optimisers:
            v = np.asarray(row.get(o, ()), dtype=float)
            if v.size == 0:
                cells[t][o] = Cell(np.nan, np.nan, 0, "", False)
                continue
            mark = "" if o == reference or reference is None else wilcoxon_mark(ref, v, alpha)
            if mark:
                counts[o]["+~-".index(mark)] += 1
            cells[t][o] = Cell(float(v.mean()), float(v.std()), int(v.size), mark,
                               means[o] == low)
    return ScoreTable(list(tasks), list(optimisers), reference, cells,
                      {o: (c[0], c[1], c[2]) for o, c in counts.items()})

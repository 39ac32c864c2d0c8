"""The benchmark's figures, drawn to be read in ten seconds (matplotlib Agg, no pyplot state).

Every figure says in its title what it compares and on which protocol (start mode, budget,
runs), labels its axes with units, keeps its legend outside the data, gives each optimiser the
same colour in every figure (:func:`optimiser_style`), switches the score axis to a log scale
when the scores span a decade or more (a uniform start gives 300..40,000), and tells feasible
runs (filled markers, solid routes) from infeasible ones (crosses, dotted routes).

- :func:`convergence_figure`: median incumbent score against evaluations on one task, the
  25-75 % band, and every run's final score at the right edge.
- :func:`scores_figure`: every run's final score per task and optimiser, with the median and
  the 25-75 % box (the table's numbers as a picture).
- :func:`paths_figure`: each optimiser's best route on a few tasks, one small map per optimiser,
  beside the best-known route.
- :func:`imax_figure`: the I_max study (paper Fig. 4), last population's feasible rate.
- :func:`ablation_figure`: the ablation study (paper Fig. 3), normalised performance per run
  (final / initial score) per variant.

Each ``*_figure`` returns the Figure; :func:`save` writes it (PNG, atomically).
"""

from __future__ import annotations

import io
import math
import zlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from planner_core.atomic import write_bytes_atomic
from planner_core.defaults import SCORE_FACTOR
from planner_core.model.formulas import penalised_score
from planner_core.textio import counted

__all__ = [
    "DPI",
    "SCORE_LABEL",
    "ablation_figure",
    "convergence_figure",
    "imax_figure",
    "optimiser_style",
    "paths_figure",
    "protocol_text",
    "save",
    "scan_figure",
    "scores_figure",
    "use_log_scale",
]

#: resolution of the PNGs: at the figure sizes below the docs show them at about their own width
DPI = 110

#: the score axis' label (f is the paper's weighted flight + hover time, in seconds)
SCORE_LABEL = f"score f + {SCORE_FACTOR:g}·φ\n(f: weighted time in s; lower is better)"

#: one colour per optimiser in every figure; a fixed-length or LP/memetic variant shares its
#: family's hue, lighter, and is drawn dashed (Tableau palette)
_COLOURS: dict[str, str] = {
    "de-adaptive": "#1f77b4", "de-adaptive-fixedlen": "#6baed6",
    "de-lamde": "#9467bd", "de-lamde-fixedlen": "#c5b0d5",
    "de-random": "#ff7f0e", "de-random-fixedlen": "#fdae6b",
    "de-fixed": "#8c564b", "de-fixed-fixedlen": "#c49c94",
    "cmaes": "#d62728", "cmaes-seeded-lp": "#ff9896",
    "planner": "#2ca02c", "planner-memetic": "#98df8a", "planner-no-starts": "#c7e9c0",
    "planner-lamde-s": "#31a354",
    "engineering-own-order": "#9edae5",
    "seed-lp": "#e377c2",
    "scipy-de": "#bcbd22",
    "lsrtde": "#17becf",
    "cmocso": "#dbdb8d",
    "random-search": "#7f7f7f",
    # the ablation variants (benchmarks/ablations.py): LAMDE and LAMDE-F in de-lamde's hues
    "LAMDE": "#9467bd", "LAMDE-F": "#c5b0d5", "LAMDE-R": "#393b79", "LAMDE-E": "#637939",
    "LAMDE-L": "#8c6d31", "LAMDE-O": "#843c39",
}
_DASHED = ("-fixedlen", "-memetic", "-seeded-lp")
#: colours for names outside the table (chosen by a stable hash of the name)
_SPARE = ("#393b79", "#637939", "#8c6d31", "#843c39", "#7b4173", "#3182bd", "#e6550d")

#: start modes as a title says them
_INIT_WORDS = {"uniform": "uniform start (paper protocol)",
               "seeded": "seeded start (sensor-aware initial population)"}


def optimiser_style(name: str) -> dict[str, Any]:
    """Line style of optimiser `name`: {"color", "ls"}, the same in every figure.

    The configurator names of `benchmarks/validate_policy.py` (adaptive, lamde, random, fixed)
    get the colours of the registry's de-<name>; other unknown names a spare colour chosen by a
    stable hash (CRC-32) of the name.

    Args:
        name: the optimiser's (or configurator's, variant's) name.

    Returns:
        {"color": hex colour, "ls": "--" for a fixed-length, memetic or seeded-LP variant, else
        "-"}.
    """
    key = name if name in _COLOURS else f"de-{name}"
    colour = _COLOURS.get(key) or _SPARE[zlib.crc32(name.encode()) % len(_SPARE)]
    return {"color": colour, "ls": "--" if name.endswith(_DASHED) else "-"}


def protocol_text(init: str | Sequence[str] | None, budget: int | None,
                  runs: int | Sequence[int] | None, per: str = "optimiser and task") -> str:
    """The protocol as a title line, e.g. "uniform start (paper protocol) · 10,000 evaluations
    per run · 2 runs per optimiser and task" (each part left out when unknown).

    Args:
        init: start mode(s), or None.
        budget: evaluations per run, or None (0 is left out too).
        runs: runs per cell, or the distinct counts (shown as a range), or None.
        per: names what the runs are counted per.

    Returns:
        The parts joined by " · " ("" when none is known).
    """
    parts = []
    inits = [init] if isinstance(init, str) else list(init or [])
    if inits:
        parts.append(" and ".join(_INIT_WORDS.get(i, f"{i} start") for i in inits))
    if budget:
        parts.append(f"{int(budget):,} evaluations per run")
    counts = sorted({runs} if isinstance(runs, int) else set(runs or []))
    if counts:
        n = counted(counts[0], "run") if len(counts) == 1 else f"{counts[0]}-{counts[-1]} runs"
        parts.append(f"{n} per {per}")
    return " · ".join(parts)


def use_log_scale(values: Any) -> bool:
    """True when the finite `values` are all positive and span a factor of 10 or more (one
    decade); a zero or negative value keeps the axis linear (a log axis would hide it).

    Args:
        values: numbers, any shape (non-finite ones ignored).

    Returns:
        Whether to use a log axis (False for fewer than two finite values).
    """
    v = np.asarray(values, dtype=float).ravel()
    v = v[np.isfinite(v)]
    return v.size > 1 and float(v.min()) > 0 and float(v.max()) >= 10.0 * float(v.min())


def save(fig: Any, path: str | Path) -> Path:
    """Write `fig` as PNG to `path` (temp file then rename) at `DPI`; return the path.

    Args:
        fig: a matplotlib Figure.
        path: the PNG file; a missing folder is created.

    Returns:
        The path written.

    Raises:
        OSError: the folder cannot be written.
    """
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    return write_bytes_atomic(Path(path), buf.getvalue())


def _new_figure(figsize: tuple[float, float]) -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _score_axis(ax: Any, values: Any) -> None:
    """Log score axis when the scores span decades (plain numbers on the ticks), else linear."""
    from matplotlib.ticker import FuncFormatter

    if use_log_scale(values):
        ax.set_yscale("log")
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:,.0f}"))
        ax.yaxis.set_minor_formatter(FuncFormatter(_minor_label))
        ax.set_ylabel(SCORE_LABEL.replace("\n", ", log scale\n", 1))
    else:
        ax.set_ylabel(SCORE_LABEL)
    ax.grid(True, which="major", alpha=0.35)
    ax.grid(True, which="minor", alpha=0.12)


def _suptitle(fig: Any, what: str, protocol: str) -> None:
    """Title of the figure: what is compared, then the protocol, each line wrapped to the
    figure's width."""
    import textwrap

    chars = max(40, int(fig.get_figwidth() * 12))
    lines = [ln for part in (what, protocol) if part for ln in textwrap.wrap(part, chars)]
    fig.suptitle("\n".join(lines), fontsize=10)


def _minor_label(v: float, _: Any) -> str:
    """Plain labels on the 2x and 5x minor ticks of a log axis, none on the others."""
    mantissa = v / 10 ** math.floor(math.log10(v)) if v > 0 else 0.0
    return f"{v:,.0f}" if round(mantissa, 6) in (2.0, 5.0) else ""


def _feasibility_handles() -> list[Any]:
    from matplotlib.lines import Line2D

    return [Line2D([], [], ls="", marker="o", color="0.25", label="run ended feasible (φ = 0)"),
            Line2D([], [], ls="", marker="x", color="0.25", mew=1.6,
                   label="run ended infeasible (φ > 0)")]


def _run_markers(ax: Any, x: np.ndarray, scores: Sequence[float], feasible: Sequence[bool],
                 colour: str) -> None:
    feas = np.asarray(feasible, dtype=bool)
    y = np.asarray(scores, dtype=float)
    if feas.any():
        ax.scatter(x[feas], y[feas], s=22, marker="o", color=colour, edgecolors="0.15",
                   linewidths=0.5, zorder=4)
    if (~feas).any():
        ax.scatter(x[~feas], y[~feas], s=30, marker="x", color=colour, linewidths=1.6,
                   zorder=4)


# ----------------------------------------------------------------------------- convergence


def _step_on_grid(ev: Sequence[int], values: Sequence[float], grid: np.ndarray) -> np.ndarray:
    """Value current at each grid point (NaN before the first entry) of a step trace."""
    idx = np.searchsorted(np.asarray(ev, dtype=float), grid, side="right") - 1
    v = np.asarray(values, dtype=float)
    return np.where(idx >= 0, v[np.clip(idx, 0, len(v) - 1)], np.nan)


def convergence_figure(task: str, per_opt: Mapping[str, Sequence[Mapping[str, Any]]],
                       opts: Sequence[str], budget: int, *, init: str | None = None) -> Any:
    """Median (25-75 % band) of the incumbent's score f + 10 phi against evaluations on `task`.

    Each run's final score is a marker right of the curves: a dot when the run ended
    feasible, a cross when not; the legend says how many were feasible.

    Args:
        task: the task's name (title).
        per_opt: per_opt[o]: benchmark records (`history` with evaluations, best_f, best_phi;
            `score`, `feasible`) of optimiser o.
        opts: the optimisers, in legend order (those without records are left out).
        budget: evaluations per run (the x axis and the budget line).
        init: the start mode, for the title.

    Returns:
        The Figure.
    """
    from matplotlib.lines import Line2D

    fig = _new_figure((9.2, 4.8))
    ax = fig.add_subplot()
    grid = np.linspace(0, budget, 201)[1:]
    shown = [o for o in opts if per_opt.get(o)]
    handles, values, counts = [], [], set()
    for i, o in enumerate(shown):
        runs = per_opt[o]
        counts.add(len(runs))
        st = optimiser_style(o)
        curves = []
        for r in runs:
            h = r["history"]
            score = penalised_score(np.asarray(h["best_f"], float),
                                    np.asarray(h["best_phi"], float))
            curves.append(_step_on_grid(h["evaluations"], score, grid))
        C = np.vstack(curves)
        ok = ~np.all(np.isnan(C), axis=0)
        med = np.nanmedian(C[:, ok], axis=0)
        lo, hi = np.nanpercentile(C[:, ok], [25, 75], axis=0)
        ax.plot(grid[ok], med, color=st["color"], ls=st["ls"], lw=1.8)
        ax.fill_between(grid[ok], lo, hi, color=st["color"], alpha=0.15, lw=0)
        final = [float(r["score"]) for r in runs]
        feas = [bool(r["feasible"]) for r in runs]
        x_end = budget * (1.03 + 0.025 * i) * np.ones(len(runs))
        _run_markers(ax, x_end, final, feas, st["color"])
        values += list(med) + final
        handles.append(Line2D([], [], color=st["color"], ls=st["ls"], lw=1.8,
                              label=f"{o} ({sum(feas)}/{len(runs)} feasible)"))
    _score_axis(ax, values)
    x_max = budget * (1.06 + 0.025 * len(shown))
    ax.set_xlim(0, x_max)
    ax.axvline(budget, color="0.5", lw=0.8, ls=":")
    ax.set_xticks([t for t in ax.get_xticks() if 0 <= t <= budget])
    ax.text((budget + x_max) / 2, 1.0, "final\nscores", transform=ax.get_xaxis_transform(),
            ha="center", va="bottom", fontsize=7.5, color="0.3")
    ax.set_xlabel(f"objective evaluations (budget {budget:,})")
    _suptitle(fig, f"{task}: best score so far against evaluations (median, 25-75 % band)",
              protocol_text(init, budget, sorted(counts)))
    fig.legend(handles=handles + _feasibility_handles(), loc="outside right center", fontsize=9,
               title="optimiser", title_fontsize=9)
    return fig


# ----------------------------------------------------------------------------- scores per task


def scores_figure(tasks: Sequence[str],
                  runs: Mapping[str, Mapping[str, Sequence[tuple[float, bool]]]],
                  opts: Sequence[str], *, what: str, protocol: str,
                  legend_title: str = "optimiser") -> Any:
    """Every run's final score per task (x) and optimiser (side by side), with its median (bar)
    and 25-75 % box; dots are feasible runs, crosses infeasible ones. Many tasks are split
    over two rows sharing the score axis, so the figure stays readable at page width.

    Args:
        tasks: the tasks, in x order.
        runs: runs[task][optimiser]: (score f + 10 phi, feasible) per run.
        opts: the optimisers, in order (those without runs are left out).
        what: the first title line (what is compared).
        protocol: the second (start mode, budget, runs).
        legend_title: the legend's title.

    Returns:
        The Figure.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    shown = [o for o in opts if any(runs.get(t, {}).get(o) for t in tasks)]
    n_o = max(len(shown), 1)
    rows = 2 if len(tasks) > 8 and len(tasks) * n_o > 24 else 1
    per_row = math.ceil(len(tasks) / rows)
    chunks = [list(tasks[i:i + per_row]) for i in range(0, len(tasks), per_row)] or [[]]
    width = float(np.clip(3.4 + per_row * (0.3 + 0.16 * n_o), 7.5, 10.5))
    fig = _new_figure((width, 1.3 + 3.4 * rows))
    axes = fig.subplots(rows, 1, sharey=True, squeeze=False)[:, 0]
    values = [float(r[0]) for t in tasks for o in shown for r in (runs.get(t, {}).get(o) or [])]
    rng = np.random.default_rng(0)  # jitter only; the same figure every time
    for ax, chunk in zip(axes, chunks, strict=False):
        _score_boxes(ax, chunk, runs, shown, rng)
        _score_axis(ax, values)
    if values:
        lo, hi = min(values), max(values)
        if axes[0].get_yscale() == "log":
            axes[0].set_ylim(lo / 1.3, hi * 1.3)
        else:
            pad = 0.08 * (hi - lo if hi > lo else abs(hi) or 1.0)
            axes[0].set_ylim(lo - pad, hi + pad)
    _suptitle(fig, what, protocol)
    handles: list[Any] = [Patch(facecolor=optimiser_style(o)["color"], alpha=0.6,
                                edgecolor=optimiser_style(o)["color"], label=o) for o in shown]
    handles += _feasibility_handles() + [
        Line2D([], [], color="0.25", lw=2.2, label="median; box: 25-75 %")]
    fig.legend(handles=handles, loc="outside right center", fontsize=9, title=legend_title,
               title_fontsize=9)
    return fig


def _score_boxes(ax: Any, tasks: list[str],
                 runs: Mapping[str, Mapping[str, Sequence[tuple[float, bool]]]],
                 shown: list[str], rng: np.random.Generator) -> None:
    """One group per task on `ax`: per optimiser a 25-75 % box, the median bar and the runs."""
    from matplotlib.patches import Rectangle

    slot = 0.8 / max(len(shown), 1)
    for j, o in enumerate(shown):
        st = optimiser_style(o)
        for k, t in enumerate(tasks):
            rs = runs.get(t, {}).get(o) or []
            if not rs:
                continue
            s = np.array([r[0] for r in rs], dtype=float)
            x0 = k - 0.4 + slot * (j + 0.5)
            q1, med, q3 = np.percentile(s, [25, 50, 75])
            ax.add_patch(Rectangle((x0 - 0.4 * slot, q1), 0.8 * slot, max(q3 - q1, 0.0),
                                   facecolor=st["color"], alpha=0.22, edgecolor=st["color"],
                                   lw=0.8, ls=st["ls"]))
            ax.plot([x0 - 0.42 * slot, x0 + 0.42 * slot], [med, med], color=st["color"], lw=2.2)
            jitter = rng.uniform(-0.25, 0.25, len(s)) * slot
            _run_markers(ax, x0 + jitter, s, [bool(r[1]) for r in rs], st["color"])
    for k in range(1, len(tasks)):
        ax.axvline(k - 0.5, color="0.85", lw=0.8)
    ax.set_xticks(range(len(tasks)))
    long_names = max((len(t) for t in tasks), default=0) > 6
    ax.set_xticklabels(tasks, rotation=20 if long_names else 0,
                       ha="right" if long_names else "center")
    ax.set_xlim(-0.5, len(tasks) - 0.5)
    ax.set_xlabel("task (map)")


# ----------------------------------------------------------------------------- best paths


def _draw_map(ax: Any, m: Any) -> None:
    from matplotlib.patches import Circle, Polygon

    km = 1e-3
    ax.add_patch(Polygon(np.array([[0, 0], [m.width, 0], [m.width, m.height], [0, m.height]])
                         * km, closed=True, fill=False, ec="0.3", lw=0.8, ls="--"))
    for c in m.spec.obstacles.circles:
        ax.add_patch(Circle((c.x * km, c.y * km), c.radius * km, fc="0.55", ec="0.35", lw=0.4))
    for poly in m.rectangle_polygons:
        ax.add_patch(Polygon(np.asarray(poly) * km, closed=True, fc="0.6", ec="0.35", lw=0.4))
    for sh in getattr(m, "shapes", ()):
        if sh.kind == "no_fly_zone":
            ax.add_patch(Polygon(np.asarray(sh.shell) * km, closed=True,
                                 fc=(0.84, 0.15, 0.16, 0.15), ec="#d62728", lw=0.8, hatch="//"))
        else:
            ax.add_patch(Polygon(np.asarray(sh.shell) * km, closed=True, fc="0.6", ec="0.35",
                                 lw=0.4))
    s = np.asarray(m.sensors, float) * km
    ax.scatter(s[:, 0], s[:, 1], s=14, marker="^", c="#2ca02c", edgecolors="0.2",
               linewidths=0.3, zorder=4)
    ax.plot(m.start[0] * km, m.start[1] * km, marker="o", c="k", ms=6, zorder=6)
    ax.plot(m.end[0] * km, m.end[1] * km, marker="s", c="k", ms=6, zorder=6)
    ax.set_xlim(-0.03 * m.width * km, 1.03 * m.width * km)
    ax.set_ylim(-0.03 * m.height * km, 1.03 * m.height * km)
    ax.set_aspect("equal")
    ax.tick_params(labelsize=8)


def _overprints(fig: Any) -> list[str]:
    """Where the figure's text overprints, as it was last drawn: a panel (an axes with its
    title, tick labels and axis labels) over, or within 2 points of, another panel, the
    figure's title or its legend.

    Args:
        fig: a drawn matplotlib Figure (its layout as the last draw left it).

    Returns:
        One description per overlapping pair ("T05 · de-adaptive / T01 · de-adaptive"), empty
        when every panel is clear. Cost grows with the square of the number of axes.
    """
    r = fig.canvas.get_renderer()
    pad = fig.dpi / 72  # 1 point each side: boxes closer than 2 points touch

    def name(ax: Any) -> str:
        return ax.get_title().split("\n")[0] or f"axes {fig.axes.index(ax)}"

    boxes = [(name(ax), ax.get_tightbbox(r).padded(pad)) for ax in fig.axes
             if ax.get_visible()]
    others = [(f"figure {what}", art.get_window_extent(r).padded(pad))
              for what, art in (("title", fig._suptitle), *(("legend", g) for g in fig.legends))
              if art is not None and art.get_visible()]
    out = [f"{a} / {b}" for i, (a, ba) in enumerate(boxes) for b, bb in boxes[i + 1:]
           if ba.overlaps(bb)]
    return out + [f"{a} / {b}" for a, ba in boxes for b, bb in others if ba.overlaps(bb)]


def _settle_layout(fig: Any, passes: int = 3) -> int:
    """Lay `fig` out again until, drawn as `save` draws it, no text overprints (`_overprints`).

    Constrained layout measures each panel's title and axis labels where the previous pass
    left its fixed-aspect map; in a short figure (a grid of one to three rows) the first pass
    can leave too little room between rows (a 2-task figure's x axis labels overprinted the
    next row's titles, the figure's title the top row's). Each pass here is one more layout
    from where the last one left the panels. A figure clear at once is left as it was, so it
    saves as before (a 16-row one, as the committed figures, byte for byte).

    Args:
        fig: a Figure with the constrained layout engine.
        passes: the most extra layout passes.

    Returns:
        The extra passes run (0: none were needed). Each costs a draw of the figure without
        rendering, and the check one more, on a copy (pickle) drawn at `DPI`.
    """
    import pickle

    from matplotlib.backends.backend_agg import FigureCanvasAgg

    extra = 0
    while True:
        probe = pickle.loads(pickle.dumps(fig))  # the next save's pass, on a copy
        FigureCanvasAgg(probe)
        probe.set_dpi(DPI)
        probe.draw_without_rendering()
        if extra == passes or not _overprints(probe):
            return extra
        fig.draw_without_rendering()
        extra += 1


def _route(m: Any, hover_points: Any) -> np.ndarray:
    hp = np.asarray(hover_points, float).reshape(-1, 2)
    return np.vstack([m.start, hp, m.end]) * 1e-3


def paths_figure(tasks: Sequence[str], maps: Mapping[str, Any],
                 best: Mapping[str, Mapping[str, Mapping[str, Any]]], opts: Sequence[str], *,
                 known: Mapping[str, Mapping[str, Any]] | None = None,
                 protocol: str = "", runs: int | None = None) -> Any:
    """One small map per task and optimiser with that optimiser's best route (solid when
    feasible, dotted and marked INFEASIBLE when not) over the best-known route (wide grey).
    Panels of one task fill rows of up to three; the panel title gives the task, optimiser
    and score. Axes in km. Laid out until no text overprints (`_settle_layout`: a grid of few
    rows needs more than one pass of the constrained layout).

    Args:
        tasks: the tasks to draw.
        maps: task -> its loaded map (`planner_core.model.mapio.Map`).
        best: best[task][optimiser]: the record of its lowest-score run (hover_points, score,
            feasible).
        opts: the optimisers, in order.
        known: known[task]: a best-known entry (hover_points, f, optimiser).
        protocol: the title's protocol text.
        runs: runs per optimiser, named in the title when given.

    Returns:
        The Figure.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    cols = 3
    blocks = []
    for t in tasks:
        shown = [o for o in opts if best.get(t, {}).get(o)]
        blocks.append((t, shown, max(1, math.ceil(len(shown) / cols))))
    rows = sum(b[2] for b in blocks)
    fig = _new_figure((3.3 * cols, 3.35 * rows + 1.1))
    gs = fig.add_gridspec(rows, cols)
    row = 0
    for t, shown, n_rows in blocks:
        m = maps[t]
        k_entry = (known or {}).get(t)
        for i, o in enumerate(shown):
            ax = fig.add_subplot(gs[row + i // cols, i % cols])
            _draw_map(ax, m)
            if k_entry is not None:
                P = _route(m, k_entry["hover_points"])
                ax.plot(P[:, 0], P[:, 1], color="0.55", lw=3.2, alpha=0.45, zorder=2,
                        solid_capstyle="round")
            r = best[t][o]
            st = optimiser_style(o)
            P = _route(m, r["hover_points"])
            feasible = bool(r["feasible"])
            ax.plot(P[:, 0], P[:, 1], color=st["color"], lw=1.6, marker="o", ms=3,
                    ls="-" if feasible else ":", mfc=st["color"] if feasible else "white",
                    zorder=5)
            verdict = "feasible" if feasible else "INFEASIBLE"
            ax.set_title(f"{t} · {o}\nscore {float(r['score']):,.1f}, {verdict}", fontsize=9,
                         color="0.1" if feasible else "#b2182b")
            ax.set_xlabel("x east (km)", fontsize=8)
            ax.set_ylabel("y north (km)", fontsize=8)
        row += n_rows
    lead = "Best route of each optimiser"
    if runs:
        lead += f" (lowest f + {SCORE_FACTOR:g}·φ of its {counted(int(runs), 'run')})"
    if any((known or {}).get(t) for t in tasks):
        lead += ", against the best-known route"
    _suptitle(fig, lead, protocol)
    handles = [
        *([Line2D([], [], color="0.55", lw=3.2, alpha=0.45, label="best-known route")]
          if any((known or {}).get(t) for t in tasks) else []),
        Line2D([], [], color="0.2", lw=1.6, marker="o", ms=3, label="route, feasible"),
        Line2D([], [], color="0.2", lw=1.6, ls=":", marker="o", ms=3, mfc="white",
               label="route, infeasible"),
        Patch(fc="0.6", ec="0.35", label="obstacle"),
        Patch(fc=(0.84, 0.15, 0.16, 0.15), ec="#d62728", hatch="//", label="no-fly zone"),
        Line2D([], [], ls="", marker="^", color="#2ca02c", label="sensor"),
        Line2D([], [], ls="", marker="o", color="k", label="start"),
        Line2D([], [], ls="", marker="s", color="k", label="end"),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=4, fontsize=9)
    _settle_layout(fig)
    return fig


# ----------------------------------------------------------------------------- I_max study


def imax_figure(tables: Mapping[str, Mapping[str, Mapping[int, tuple[float, float, int]]]], *,
                n_tasks: int, runs: int, budget: int | None) -> Any:
    """The I_max study (paper Fig. 4): mean ± std of the last population's feasible rate
    against I_max, per optimiser (filled markers for the first start mode, open for the
    next).

    Args:
        tables: tables[init][optimiser][i_max] = (mean, std, n) (`report.imax_table`).
        n_tasks: tasks the study ran on (title).
        runs: runs per cell (title).
        budget: evaluations per run, or None when mixed (title).

    Returns:
        The Figure.
    """
    from matplotlib.lines import Line2D

    fig = _new_figure((8.4, 4.4))
    ax = fig.add_subplot()
    modes = [m for m in tables if tables[m]]
    handles = []
    marker = {"uniform": "o", "seeded": "s"}
    for m_i, mode in enumerate(modes):
        for j, (o, d) in enumerate(tables[mode].items()):
            st = optimiser_style(o)
            xs = sorted(d)
            shift = (j - (len(tables[mode]) - 1) / 2) * 0.6  # side by side: bars do not overlap
            ax.errorbar(np.asarray(xs, float) + shift, [d[k][0] for k in xs],
                        yerr=[d[k][1] for k in xs], color=st["color"], ls=st["ls"], lw=1.8,
                        marker=marker.get(mode, "D"), ms=5, capsize=3,
                        mfc=st["color"] if m_i == 0 else "white")
            label = o if len(modes) == 1 else f"{o}, {mode} start"
            handles.append(Line2D([], [], color=st["color"], ls=st["ls"], lw=1.8,
                                  marker=marker.get(mode, "D"), label=label))
    ks = sorted({k for mode in modes for d in tables[mode].values() for k in d})
    ax.set_xticks(ks)
    ax.set_xlabel("I_max: hover points in the encoding (uav.max_hover_points)")
    ax.set_ylabel("share of the last population with φ = 0\n(mean ± std over tasks and runs)")
    ax.set_ylim(-0.05, 1.05)
    ax.grid(True, alpha=0.35)
    _suptitle(fig, "Feasible share of the last population against I_max (paper Fig. 4)",
              protocol_text(modes, budget, runs) + f" · {n_tasks} tasks")
    fig.legend(handles=handles, loc="outside right center", fontsize=9, title="optimiser",
               title_fontsize=9)
    return fig


def ablation_figure(values: Mapping[str, Sequence[float]], protocol: str) -> Any:
    """The ablation study (paper Fig. 3): one box per variant (median, 25-75 %, whiskers at 1.5
    IQR, outliers) of the normalised performance of its runs, final / initial score (lower is
    better), with the mean as a diamond. Log axis when the values span a decade.

    Args:
        values: values[variant]: normalised performances of its runs, in the order to draw.
        protocol: the title's protocol text (:func:`protocol_text`).

    Returns:
        The Figure.
    """
    names = list(values)
    fig = _new_figure((1.3 * len(names) + 2.6, 4.4))
    ax = fig.add_subplot()
    data = [np.asarray(values[o], dtype=float) for o in names]
    x = np.arange(1, len(names) + 1)
    box = ax.boxplot(data, positions=x, widths=0.55, patch_artist=True, showfliers=True)
    for patch, o in zip(box["boxes"], names, strict=True):
        patch.set(facecolor=optimiser_style(o)["color"], alpha=0.35)
    for med in box["medians"]:
        med.set(color="k", lw=1.4)
    ax.plot(x, [float(np.mean(v)) for v in data], "D", color="k", ms=5, label="mean")
    ax.set_xticks(x, names, fontsize=8)
    if use_log_scale(np.concatenate(data) if data else []):
        ax.set_yscale("log")
    ax.set_ylabel("final / initial score per run\n(lower is better)")
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    _suptitle(fig, "Ablations: normalised performance per run", protocol)
    return fig


def scan_figure(panels: Mapping[str, Sequence[tuple[float, str, int, int, Sequence[str]]]],
                reference: str, what: str, protocol: str) -> Any:
    """A configuration scan (`benchmarks/validate_policy.py --configurators grid`): one panel
    per pipeline, one point per configurator at (share of feasible runs, geometric mean over
    the maps of its median score over the reference's; below 1 is better), the static
    configurations grey, named configurators in their colours; a ring marks a configurator
    significantly better than the reference on at least 12 of the maps (`rows[i][4]` are its
    per-map Wilcoxon marks).

    Args:
        panels: panels[pipeline]: `validate_policy.scan_rows` rows, each (score ratio,
            configurator label ("fixed:..." for a static one), feasible runs, runs, per-map
            marks).
        reference: the reference configurator's name (axis label and legend).
        what: the first title line.
        protocol: the title's protocol text.

    Returns:
        The Figure.
    """
    names = list(panels)
    fig = _new_figure((4.2 * len(names) + 0.6, 4.4))
    axes = fig.subplots(1, len(names), squeeze=False, sharey=True)[0]
    for ax, name in zip(axes, names, strict=True):
        rows = panels[name]
        for ratio, label, feas, runs, marks in rows:
            x, static = 100.0 * feas / max(runs, 1), label.startswith("fixed:")
            colour = "0.6" if static else optimiser_style(label)["color"]
            ax.plot([x], [ratio], "o", color=colour, ms=4 if static else 7,
                    zorder=2 if static else 3)
            if list(marks).count("+") >= 12:
                ax.plot([x], [ratio], "o", mfc="none", mec="k", ms=12, zorder=4)
        ax.axhline(1.0, color="k", lw=0.8, alpha=0.5)
        ax.axvline(95.0, color="k", lw=0.8, ls=":", alpha=0.7)
        ax.set_xlim(-3, 103)
        ax.set_xlabel("feasible runs (%)")
        ax.set_title(f"pipeline: {name}", fontsize=9)
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel(f"median score / {reference}'s\n(geometric mean over maps; lower is "
                       "better)")
    from matplotlib.lines import Line2D

    named = dict.fromkeys(label for rows in panels.values() for _, label, *_ in rows
                          if not label.startswith("fixed:"))
    handles = [Line2D([], [], ls="", marker="o", ms=7, color=optimiser_style(n)["color"],
                      label=n) for n in named]
    handles += [Line2D([], [], ls="", marker="o", ms=4, color="0.6", label="static (fixed:...)"),
                Line2D([], [], ls="", marker="o", ms=12, mfc="none", mec="k",
                       label=f"better than {reference}\non >= 12 maps"),
                Line2D([], [], ls=":", color="k", lw=0.8, label="95 % feasible")]
    fig.legend(handles=handles, loc="outside right center", fontsize=9, title="configurator")
    _suptitle(fig, what, protocol)
    return fig

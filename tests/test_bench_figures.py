"""The benchmark figures are rendered and read back: file written, non-empty PNG, the title names
what is compared and the protocol, axes carry units, the legend names every optimiser and the
feasible/infeasible markers and lies outside the data, a log score axis where scores span
decades, one colour per optimiser in every figure."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from planner_core.bench import figures as F
from tests.conftest import ROOT

PNG = b"\x89PNG\r\n\x1a\n"


def _texts(fig: Any) -> list[str]:
    from matplotlib.text import Text

    return [t.get_text().replace("\n", " ") for t in fig.findobj(Text) if t.get_text()]


def _has(fig: Any, *needles: str) -> None:
    texts = _texts(fig)
    for n in needles:
        assert any(n in t for t in texts), f"{n!r} not in the figure's text: {texts}"


def _legend_clear_of_axes(fig: Any) -> None:
    """Every legend (a figure legend) lies outside every axes' box."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    assert fig.legends, "no figure legend"
    for leg in fig.legends:
        lb = leg.get_window_extent(r)
        for ax in fig.axes:
            assert not lb.overlaps(ax.get_window_extent(r)), "legend over the data"


def _saved(fig: Any, path: Path) -> None:
    out = F.save(fig, path)
    data = out.read_bytes()
    assert out == path and data[:8] == PNG and len(data) > 10_000


def _record(opt: str, run: int, final: float, feasible: bool, start: float) -> dict[str, Any]:
    phi = 0.0 if feasible else 3.0
    ev = [100, 2_000, 6_000, 10_000]
    f = list(np.geomspace(start, final - 10 * phi, len(ev)))
    return {"optimiser": opt, "task": "T09", "run": run, "score": final, "feasible": feasible,
            "history": {"evaluations": ev, "best_f": f, "best_phi": [phi] * len(ev)}}


def test_convergence_figure_says_what_and_how(tmp_path: Path) -> None:
    per = {"de-adaptive": [_record("de-adaptive", 0, 3_100.0, True, 20_000),
                           _record("de-adaptive", 1, 3_300.0, False, 18_000)],
           "cmaes": [_record("cmaes", 0, 11_000.0, False, 23_000),
                     _record("cmaes", 1, 2_700.0, True, 21_000)]}
    fig = F.convergence_figure("T09", per, ["de-adaptive", "cmaes"], 10_000, init="uniform")
    _has(fig, "T09: best score so far against evaluations", "uniform start (paper protocol)",
         "10,000 evaluations per run", "2 runs per optimiser", "objective evaluations",
         "score f + 10·φ", "weighted time in s", "de-adaptive (1/2 feasible)",
         "cmaes (1/2 feasible)", "run ended feasible", "run ended infeasible", "final")
    _legend_clear_of_axes(fig)
    assert fig.axes[0].get_yscale() == "linear"  # 2,700..23,000: under a decade
    _saved(fig, tmp_path / "c.png")


def test_scores_figure_log_scale_when_scores_span_decades(tmp_path: Path) -> None:
    runs = {"T01": {"de-adaptive": [(380.0, True), (420.0, True)],
                    "random-search": [(900.0, True), (1_000.0, True)]},
            "T16": {"de-adaptive": [(34_000.0, False), (36_000.0, False)],
                    "random-search": [(41_000.0, False), (44_000.0, True)]}}
    fig = F.scores_figure(["T01", "T16"], runs, ["de-adaptive", "random-search"],
                          what="Final score of every run per task: 2 optimisers",
                          protocol=F.protocol_text("uniform", 10_000, 2))
    ax = fig.axes[0]
    assert ax.get_yscale() == "log"
    assert [t.get_text() for t in ax.get_xticklabels()] == ["T01", "T16"]
    _has(fig, "Final score of every run per task", "uniform start", "task (map)",
         "log scale", "de-adaptive", "random-search", "run ended infeasible",
         "median; box: 25-75 %")
    _legend_clear_of_axes(fig)
    _saved(fig, tmp_path / "s.png")
    # seeded-start scores within a few per cent: a linear axis shows the differences
    near = {"T01": {"de-adaptive": [(295.3, True), (296.1, True)],
                    "scipy-de": [(296.0, True), (297.2, True)]}}
    fig = F.scores_figure(["T01"], near, ["de-adaptive", "scipy-de"], what="x", protocol="y")
    assert fig.axes[0].get_yscale() == "linear"


def test_paths_figure_one_map_per_optimiser(tmp_path: Path) -> None:
    from planner_core.model.mapio import load_map

    m = load_map(ROOT / "examples" / "maps" / "suite" / "T01.json")
    hp = [[1_000.0, 1_000.0], [3_000.0, 2_000.0]]
    best = {"T01": {"de-adaptive": {"hover_points": hp, "score": 325.5, "feasible": True},
                    "lsrtde": {"hover_points": hp[::-1], "score": 9_268.3, "feasible": False}}}
    known = {"T01": {"hover_points": hp, "f": 295.0, "optimiser": "de-adaptive"}}
    fig = F.paths_figure(["T01"], {"T01": m}, best, ["de-adaptive", "lsrtde"], known=known,
                         protocol=F.protocol_text("seeded", 10_000, 2), runs=2)
    assert len(fig.axes) == 2
    _has(fig, "Best route of each optimiser (lowest f + 10·φ of its 2 runs)",
         "seeded start", "T01 · de-adaptive", "score 325.5, feasible", "T01 · lsrtde",
         "score 9,268.3, INFEASIBLE", "x east (km)", "y north (km)", "best-known route",
         "route, infeasible", "no-fly zone", "sensor", "start", "end")
    _legend_clear_of_axes(fig)
    _saved(fig, tmp_path / "p.png")
    bare = F.paths_figure(["T01"], {"T01": m}, best, ["de-adaptive"], protocol="p", runs=2)
    assert not any("best-known" in t for t in _texts(bare))  # no route, no legend entry


def _saved_layout(fig: Any, path: Path) -> dict[str, Any]:
    """Save `fig` as the report does, then measure its text where the saved PNG has it (the
    layout engine off, so drawing again moves nothing): panel tight boxes (title, tick and axis
    labels) by row, top to bottom, and the figure title's and legend's boxes, in pixels."""
    F.save(fig, path)
    fig.set_layout_engine("none")
    fig.set_dpi(F.DPI)
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    rows: dict[float, list[Any]] = {}
    for ax in fig.axes:
        rows.setdefault(round(ax.get_position().y0, 3), []).append(ax.get_tightbbox(r))
    return {"rows": [rows[y] for y in sorted(rows, reverse=True)],
            "title": fig._suptitle.get_window_extent(r),
            "legend": fig.legends[0].get_window_extent(r)}


@pytest.mark.slow  # measured 5.4 s beside a CI run (issue 35: default suite <= 5 min)
def test_paths_figure_of_few_tasks_keeps_its_rows_apart(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """`report`'s best paths on 2 tasks: the top row's "x east (km)" overprinted the bottom
    row's titles ("T05 · de-adaptive"), the figure title the top row's, the legend the bottom
    row's axis labels (one pass of the constrained layout with fixed-aspect maps in a short
    figure). Now every row clears the next, the title and the legend by 2 points or more; a
    figure clear at once (3 tasks here, and a 16-row one like the committed figures) gets no extra
    layout pass, so it saves as before."""
    from planner_core.model.mapio import load_map

    passes: list[int] = []
    settle = F._settle_layout
    monkeypatch.setattr(F, "_settle_layout", lambda fig: passes.append(settle(fig)))
    tasks = ["T01", "T05", "T06"]
    maps = {t: load_map(ROOT / "examples" / "maps" / "suite" / f"{t}.json") for t in tasks}
    opts = ["de-adaptive", "cmaes", "random-search"]
    best = {t: {o: {"hover_points": [[1_000.0, 1_000.0], [3_000.0, 2_000.0]], "score": 325.5,
                    "feasible": o != "cmaes"} for o in opts} for t in tasks}
    protocol = F.protocol_text("seeded", 300, 2)
    gap = 2 * F.DPI / 72  # 2 points, in pixels
    for n in (2, 3):
        fig = F.paths_figure(tasks[:n], maps, best, opts, protocol=protocol, runs=2)
        lay = _saved_layout(fig, tmp_path / f"p{n}.png")
        assert len(lay["rows"]) == n
        for upper, lower in zip(lay["rows"], lay["rows"][1:], strict=False):
            assert min(b.y0 for b in upper) - max(b.y1 for b in lower) >= gap, n
        assert lay["title"].y0 - max(b.y1 for b in lay["rows"][0]) >= gap, n
        assert min(b.y0 for b in lay["rows"][-1]) - lay["legend"].y1 >= gap, n
    assert passes[0] > 0 and passes[-1] == 0, passes


def test_imax_figure(tmp_path: Path) -> None:
    tables = {"uniform": {"de-adaptive": {20: (0.28, 0.41, 48), 100: (0.16, 0.34, 48)},
                          "de-adaptive-fixedlen": {20: (0.34, 0.44, 48), 100: (0.08, 0.24, 48)}}}
    fig = F.imax_figure(tables, n_tasks=16, runs=3, budget=10_000)
    _has(fig, "Feasible share of the last population against I_max (paper Fig. 4)",
         "uniform start", "3 runs per optimiser", "16 tasks", "I_max: hover points",
         "φ = 0", "de-adaptive", "de-adaptive-fixedlen")
    _legend_clear_of_axes(fig)
    _saved(fig, tmp_path / "i.png")
    both = {**tables, "seeded": {"de-adaptive": {20: (0.9, 0.1, 48), 100: (0.7, 0.2, 48)}}}
    fig = F.imax_figure(both, n_tasks=16, runs=3, budget=10_000)
    _has(fig, "uniform start (paper protocol) and seeded start", "de-adaptive, uniform start",
         "de-adaptive, seeded start")


def test_scan_figure(tmp_path: Path) -> None:
    """The configuration scan (docs/policy.md): a panel per pipeline on one score axis, the
    named configurators in the legend, static ones grey, a ring only for a configurator better
    than the reference on >= 12 maps."""
    plus, tie = ["+"] * 12 + ["~"] * 4, ["~"] * 16
    eleven = ["+"] * 11 + ["-"] * 5
    panels = {"de": [(0.8, "adaptive", 30, 128, eleven), (1.0, "random", 25, 128, tie),
                     (1.2, "fixed:rand/1:bin:0.5:0.9", 10, 128, ["-"] * 16)],
              "memetic": [(0.9, "lamde", 125, 128, plus), (1.0, "random", 124, 128, tie)]}
    fig = F.scan_figure(panels, "random", "A scan", F.protocol_text("uniform", 10_000, 8))
    axes = fig.get_axes()
    assert len(axes) == 2 and axes[0].get_ylim() == axes[1].get_ylim()
    _has(fig, "A scan", "pipeline: de", "pipeline: memetic", "adaptive", "lamde",
         "static (fixed:...)", "95 % feasible")
    rings = [ln for ax in axes for ln in ax.get_lines() if ln.get_markerfacecolor() == "none"]
    assert len(rings) == 1 and tuple(rings[0].get_xydata()[0]) == (100 * 125 / 128, 0.9)
    _legend_clear_of_axes(fig)
    _saved(fig, tmp_path / "scan.png")


def test_one_colour_per_optimiser_in_every_figure() -> None:
    from planner_core.bench.baselines import REGISTRY

    colours = [F.optimiser_style(o)["color"] for o in REGISTRY]
    assert len(set(colours)) == len(colours)
    # validate_policy's configurator names share the registry's DE colours
    for c in ("adaptive", "lamde", "random", "fixed"):
        assert F.optimiser_style(c) == F.optimiser_style(f"de-{c}")
    assert F.optimiser_style("de-adaptive-fixedlen")["ls"] == "--"
    # a name outside the table: a spare colour by a stable hash of the name (crc32, not the
    # per-process salted hash(): the same colour in every run), solid unless a variant suffix
    assert F.optimiser_style("not-registered") == {"color": "#7b4173", "ls": "-"}
    assert F.optimiser_style("not-registered-fixedlen") == {"color": "#843c39", "ls": "--"}
    # the ablation variants: one colour each, LAMDE in de-lamde's
    variants = ("LAMDE", "LAMDE-F", "LAMDE-R", "LAMDE-E", "LAMDE-L", "LAMDE-O")
    assert len({F.optimiser_style(v)["color"] for v in variants}) == len(variants)
    assert F.optimiser_style("LAMDE")["color"] == F.optimiser_style("de-lamde")["color"]


@pytest.mark.parametrize(("values", "log"), [([300, 40_000], True), ([295, 310], False),
                                             ([100, 999], False), ([100, 1_000], True),
                                             ([0.0, 40_000], False)])
def test_log_scale_rule(values: list[float], log: bool) -> None:
    assert F.use_log_scale(values) is log


def test_protocol_text() -> None:
    assert F.protocol_text("uniform", 10_000, [2]) == (
        "uniform start (paper protocol) · 10,000 evaluations per run · 2 runs per optimiser "
        "and task")
    assert "1 run per" in F.protocol_text(None, None, 1)
    assert "16-25 runs" in F.protocol_text("seeded", None, [16, 25])


@pytest.mark.slow  # measured 54 s (issue 35: default suite <= 5 min)
def test_make_figures_redraws_the_stored_runs(tmp_path: Path) -> None:
    """`python docs/make_figures.py --out DIR` writes the committed report and every figure it
    draws; the report equals the committed one (so the docs are what the code draws), each
    figure is a PNG, and the reports whose runs are not stored are named, not redrawn."""
    import importlib.util
    import re
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "docs/make_figures.py", "--out", str(tmp_path)],
                       cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    spec = importlib.util.spec_from_file_location("make_figures", ROOT / "docs" / "make_figures.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    md = "docs/reduced/protocol.md"
    written = (tmp_path / md).read_text(encoding="utf-8")
    assert written == (ROOT / md).read_text(encoding="utf-8"), \
        f"{md} is stale: run `python docs/make_figures.py`"  # fmt: skip
    pictures = re.findall(r"!\[[^]]*\]\(([^)]+)\)", written)
    assert len(pictures) == 8  # per protocol: scores, 2 convergence, best paths
    for rel in pictures:
        png = tmp_path / "docs" / "reduced" / rel
        assert png.read_bytes()[:8] == PNG and (ROOT / "docs" / "reduced" / rel).exists()
    policy_md = (ROOT / "docs" / "policy.md").read_text(encoding="utf-8")
    for _, stem, _, _ in mod.POLICY:
        made = sorted((tmp_path / stem).parent.glob(Path(stem).name + "_*.png"))
        assert made, stem
        for png in made:
            assert png.read_bytes()[:8] == PNG and png.stat().st_size > 10_000
            rel = png.relative_to(tmp_path / "docs").as_posix()
            assert f"]({rel})" in policy_md, f"docs/policy.md does not show {rel}"
    for _, fig, _, _ in mod.SCANS:
        png = tmp_path / fig
        assert png.read_bytes()[:8] == PNG and png.stat().st_size > 10_000
        rel = Path(fig).relative_to("docs").as_posix()
        assert f"]({rel})" in policy_md, f"docs/policy.md does not show {rel}"
    for results, report, _, extra in mod.REPORTS:
        if not mod.stored(ROOT / results):  # results.jsonl, or compressed .gz
            assert f"skipped {report}" in r.stderr and results in mod.NOT_STORED
            if "--imax" in extra or "--ablations" in extra:  # its stored studies are redrawn
                assert f"redrew the study figures of {report}" in r.stderr
                page = (ROOT / report).read_text(encoding="utf-8")
                for flag, png in (("--imax", "imax_feasible_rate.png"),
                                  ("--ablations", "ablation_normalised_uniform.png")):
                    if flag in extra:
                        rel = f"{Path(report).with_suffix('').name}/{png}"
                        made = tmp_path / Path(report).parent / rel
                        assert made.read_bytes()[:8] == PNG and f"]({rel})" in page


def test_complete_seeds_drop_a_partial_last_seed() -> None:
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_figures", ROOT / "docs" / "make_figures.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    recs = [{"map": m, "mode": "uniform", "configurator": c, "seed": s}
            for s in (0, 1) for m in ("T01", "T02") for c in ("lamde", "adaptive")]
    recs += [{"map": "T01", "mode": "uniform", "configurator": "lamde", "seed": 2}]
    assert mod.complete_seeds(recs) == [0, 1]


@pytest.mark.slow  # measured 71 s (issue 35: default suite <= 5 min)
def test_a_rebuilt_report_keeps_its_hand_written_part(tmp_path: Path) -> None:
    """The report's KEEP_START ... KEEP_END block (docs/results.md's "what this shows") survives
    `lamde-mission report` over the same page, placed after the commands; other text does not."""
    from planner_core.bench.report import KEEP_END, KEEP_START, build_report

    runs = Path(__file__).resolve().parent.parent / "docs" / "reduced" / "runs"
    page = tmp_path / "r.md"
    cmd = "lamde-mission report runs -o r.md"
    build_report(runs, page, reference="de-adaptive", figures=tmp_path / "fig", command=cmd)
    first = page.read_text()
    assert KEEP_START not in first
    note = f"{KEEP_START}\n## What this shows\n\nhand-written words\n{KEEP_END}"
    page.write_text(first.replace("## Setup", note + "\n\n## Setup", 1) + "\nstray edit\n")
    build_report(runs, page, reference="de-adaptive", figures=tmp_path / "fig", command=cmd)
    again = page.read_text()
    assert again.count("hand-written words") == 1 and "stray edit" not in again
    assert again.index("Report produced by") < again.index(KEEP_START) < again.index("## Setup")
    build_report(runs, page, reference="de-adaptive", figures=tmp_path / "fig", command=cmd)
    assert page.read_text() == again

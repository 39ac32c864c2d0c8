"""docs/ keeps only the run records that a page, a doc script or a test cites, each compressed,
and stays under 10 MB (issue 35); every figure a page shows is drawn by `docs/make_figures.py`
(`make figures`) or `docs/make_gallery.py`, or is a frozen figure of a report whose runs are not
stored (`make_figures.NOT_STORED` says why)."""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from functools import cache
from pathlib import Path
from types import ModuleType

import pytest

from tests.conftest import ROOT

#: the size the checkout's docs/ must stay under (sum of the tracked files' sizes)
DOCS_LIMIT = 10_000_000
#: a file under docs/ with one of these endings is a record (runs, their metadata, checkpoints)
RECORD_SUFFIXES = (".jsonl", ".json", ".csv", ".gz", ".npz", ".log")
#: plain-text records larger than this must be stored compressed (.gz)
PLAIN_LIMIT = 64_000
#: the figures the study sections of a report draw from their stored study folders (its option)
STUDY_FIGURES = {"imax_feasible_rate.png": "--imax",
                 "ablation_normalised_uniform.png": "--ablations"}
PNG = b"\x89PNG\r\n\x1a\n"


@cache
def _tracked() -> tuple[Path, ...]:
    """The files git tracks under docs/ that are in the working tree."""
    try:
        out = subprocess.run(["git", "ls-files", "-z", "docs"], cwd=ROOT, capture_output=True,
                             check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return tuple(p for p in (ROOT / s for s in out.decode().split("\0") if s) if p.is_file())


@cache
def _citing_text() -> str:
    """Every Markdown page (the manual, the README, benchmarks/), doc script and test."""
    files = [ROOT / "README.md", *(ROOT / "docs").rglob("*.md"), *(ROOT / "docs").glob("*.py"),
             *(ROOT / "benchmarks").rglob("*.md"), *(ROOT / "tests").rglob("*.py")]
    return "\n".join(f.read_text(encoding="utf-8") for f in files if f.is_file())


def _names(path: Path) -> list[str]:
    """How a text may name a file or folder under docs/: from the repository root or from docs/."""
    rel = path.relative_to(ROOT).as_posix()
    return [rel, rel.removeprefix("docs/")]


def _cited(name: str, text: str) -> bool:
    """Whether `name` occurs in `text` as a whole path (not as part of a longer name)."""
    return name in text and re.search(r"(?<![\w.-])" + re.escape(name) + r"(?![\w.-]*\w)",
                                      text) is not None


def _benchmark_folder(path: Path) -> Path | None:
    """The stored benchmark folder (one holding meta.json) that `path` lies in, if any."""
    for folder in path.parents:
        if folder == ROOT / "docs":
            return None
        if (folder / "meta.json").is_file():
            return folder
    return None


def _is_record(path: Path) -> bool:
    return path.name.endswith(RECORD_SUFFIXES)


def test_docs_stay_under_10_mb() -> None:
    total = sum(p.stat().st_size for p in _tracked())
    assert total <= DOCS_LIMIT, (
        f"docs/ holds {total / 1e6:.1f} MB of tracked files (limit {DOCS_LIMIT / 1e6:.0f} MB): "
        "keep only the records a page cites, compressed, and no regenerated figure no page shows")


def test_every_committed_record_is_cited() -> None:
    """A record under docs/ is cited by its path (from the repository root or from docs/) in a
    page, doc script or test, or lies in a stored benchmark folder that is cited so."""
    text = _citing_text()
    uncited = []
    for path in filter(_is_record, _tracked()):
        folder = _benchmark_folder(path)
        names = _names(path) + (_names(folder) if folder else [])
        if not any(_cited(n, text) for n in names):
            uncited.append(path.relative_to(ROOT).as_posix())
    assert not uncited, ("records no page, doc script or test cites (`git rm` them; history "
                         f"keeps them): {uncited}")


def test_records_are_stored_compressed() -> None:
    plain = [p.relative_to(ROOT).as_posix() for p in filter(_is_record, _tracked())
             if p.name.endswith((".jsonl", ".json", ".csv")) and
             (p.name.endswith(".jsonl") or p.stat().st_size > PLAIN_LIMIT)]
    assert not plain, f"records to store gzip-compressed (.jsonl.gz, .json.gz, .csv.gz): {plain}"


def _make_figures() -> ModuleType:
    spec = importlib.util.spec_from_file_location("make_figures", ROOT / "docs" / "make_figures.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _shown() -> dict[Path, list[Path]]:
    """figure -> the pages that show it (images of every Markdown page, the README's too)."""
    shown: dict[Path, list[Path]] = {}
    for page in [ROOT / "README.md", *(ROOT / "docs").rglob("*.md")]:
        for target in re.findall(r"!\[[^]]*\]\(([^)\s]+)", page.read_text(encoding="utf-8")):
            if "://" not in target:
                shown.setdefault((page.parent / target).resolve(), []).append(page)
    return shown


def test_every_committed_figure_is_shown_and_every_shown_figure_is_drawn() -> None:
    """No committed PNG that no page shows; each one a page shows is the gallery's
    (make_gallery.py), drawn by make_figures.py (a report over its stored runs, its stored
    studies, a policy or scan figure), or a frozen figure of a report whose runs are not stored;
    make_figures.py's are stored as palette PNGs (`compact_png`)."""
    mf = _make_figures()
    shown = _shown()
    pngs = [p for p in _tracked() if p.suffix == ".png"]
    assert not [p for p in pngs if p.resolve() not in shown], "committed figures no page shows"
    drawn: set[Path] = set()
    for _, stem, _, _ in mf.POLICY:
        drawn |= {ROOT / f"{stem}_{mode}.png" for mode in ("seeded", "uniform")}
    drawn |= {ROOT / fig for _, fig, _, _ in mf.SCANS}
    undrawn = []
    for fig, pages in sorted(shown.items()):
        rel = fig.relative_to(ROOT).as_posix()
        if rel.startswith("docs/gallery/"):
            continue
        report = next((r for r in mf.REPORTS if fig.parent == (ROOT / r[1]).with_suffix("")),
                      None)
        if fig in drawn:
            pass
        elif report is None:
            undrawn.append(f"{rel} (shown by {pages[0].relative_to(ROOT).as_posix()})")
        elif not mf.stored(ROOT / report[0]):
            assert report[0] in mf.NOT_STORED, f"{rel}: {report[0]} is neither stored nor said why"
            if fig.name in STUDY_FIGURES:  # redrawn from the stored study folder
                assert mf.stored(ROOT / mf._option(report[3], STUDY_FIGURES[fig.name])), rel
        assert fig.read_bytes()[:8] == PNG and fig.read_bytes()[25] == 3, \
            f"{rel} is not a palette PNG: run `make figures` (docs/make_figures.py)"
    assert not undrawn, f"figures the pages show that make_figures.py does not draw: {undrawn}"


def test_search_page_table_is_what_the_stored_runs_give() -> None:
    """docs/search.md's comparison with every peer is `search_table.py`'s output on the kept
    records (the command the page gives)."""
    page = (ROOT / "docs" / "search.md").read_text(encoding="utf-8")
    cmd = re.search(r"python benchmarks/search_table\.py (docs/search/pipeline-planner"
                    r"(?:[^\n]*\\\n)*[^\n]*)", page)
    assert cmd, "docs/search.md gives no search_table.py command over the stored records"
    args = cmd.group(1).replace("\\\n", " ").split()
    r = subprocess.run([sys.executable, "benchmarks/search_table.py", *args], cwd=ROOT,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    rows = [s for s in r.stdout.splitlines() if s.startswith("| T")]
    assert len(rows) == 16 and all(row in page for row in rows), \
        "docs/search.md's table is not what the stored runs give"


def _table_rows(text: str) -> list[str]:
    """The lines of the first Markdown table in `text`."""
    lines = text[text.index("\n| Task |") + 1:].splitlines()
    return lines[:next((i for i, s in enumerate(lines) if not s.startswith("| ")
                        and not s.startswith("|---")), len(lines))]


def _cells(rows: list[str]) -> dict[tuple[str, str], str]:
    """(task, column) -> the cell's text without the bold of the best mean."""
    head = [c.strip().removesuffix(" (ref)") for c in rows[0].strip("|").split("|")]
    out = {}
    for row in rows[2:]:
        cells = [c.strip().replace("**", "") for c in row.strip("|").split("|")]
        out.update({(cells[0], h): c for h, c in zip(head[1:], cells[1:], strict=True)})
    return out


def test_results_cmocso_table_is_what_the_stored_runs_give() -> None:
    """docs/results.md's CMOCSO table is the report's score table (the report's column order,
    reference de-lamde, its marks) of the runs kept in docs/studies/cmocso/ and
    docs/metabox/results.jsonl.gz, the commands its section gives; and every column it shares
    with the page's Table 2 (uniform start) has Table 2's cells: it had compared with a
    de-lamde re-run that Table 2 and the code disagreed with (T03 368.8 against 365.3)."""
    from collections import defaultdict

    from planner_core.bench.records import read_records
    from planner_core.bench.report import format_table, order_optimisers
    from planner_core.bench.stats import score_table

    page = (ROOT / "docs" / "results.md").read_text(encoding="utf-8")
    at = page.index("## CMOCSO")
    section = page[at:page.index("\n## ", at + 1)]
    for cmd in ("merge_results.py --results docs/studies/cmocso --metabox "
                "docs/metabox/results.jsonl.gz --out RUNS",
                "lamde-mission report RUNS -o RUNS/cmocso.md --reference de-lamde"):
        assert cmd in section, cmd
    records = [r for path in ("docs/studies/cmocso/results.jsonl", "docs/metabox/results.jsonl.gz")
               for r in read_records(ROOT / path).records]
    scores: dict[str, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for r in sorted(records, key=lambda r: int(r["run"])):
        assert r["init"] == "uniform" and r.get("i_max") is None and r["budget"] == 10_000
        scores[r["task"]][r["optimiser"]].append(r["score"])
    tasks = sorted(scores)
    opts = order_optimisers({r["optimiser"] for r in records}, "de-lamde")
    assert {len(v) for t in tasks for v in scores[t].values()} == {25} and len(tasks) == 16
    table = format_table(score_table(scores, tasks, opts, "de-lamde"))
    shown = _table_rows(section)
    assert shown == table, "docs/results.md's CMOCSO table is not what the stored runs give"
    at = page.index("## Protocol: init uniform")
    main = _cells(_table_rows(page[at:page.index("### Per optimiser", at)]))
    for (task, column), cell in _cells(shown).items():
        if column != "cmocso":
            assert cell == main[(task, column)], (task, column, cell, main[(task, column)])

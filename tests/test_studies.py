"""Issue 16: the ablation and I_max studies as sections of another report (`report --imax DIR
--ablations DIR`), their slim copies kept in the repository (`benchmarks/store_runs.py`), and an
unfinished study reported on equal run counts."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from lamde_mission.cli import main
from planner_core.bench.ablation import META_KEY
from planner_core.bench.records import (
    RESULTS_FILE,
    SLIM_FIELDS,
    complete_runs,
    read_records,
    slim_record,
)
from planner_core.bench.report import build_report, imax_table, study_sections
from planner_core.bench.store import store_runs
from tests.conftest import ROOT
from tests.test_ablations import _record


def _write(folder: Path, records: list[dict], meta: dict) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / RESULTS_FILE).write_text("".join(json.dumps(r) + "\n" for r in records))
    (folder / "meta.json").write_text(json.dumps(meta))
    return folder


def _imax_record(opt: str, task: str, run: int, i_max: int, rate: float) -> dict:
    return {**_record(opt, task, run, 100.0, 100.0 - 50.0 * rate), "i_max": i_max,
            "last_feasible_rate": rate}


@pytest.fixture
def studies(tmp_path: Path) -> dict[str, Path]:
    """A main benchmark folder, an ablation folder (2 tasks x 3 runs, a policy checkpoint) and
    an unfinished I_max folder (run 2 has only one cell)."""
    main_dir = _write(tmp_path / "main", [_record(o, t, k, 100.0, 40.0 + k)
                                          for o in ("de-lamde", "de-adaptive")
                                          for t in ("T1", "T2") for k in range(3)],
                      {"suite": str(tmp_path / "nosuite"), "budget": 100,
                       "commands": [{"command": "lamde-mission bench main"}]})
    ck = tmp_path / "runs" / "train" / "LAMDE"
    ck.mkdir(parents=True)
    (ck / "curve.csv").write_text("epoch,seconds\n1,12.5\n2,7.5\n")
    (ck / "weights.npz").write_bytes(b"weights")
    (ck / "state.pt").write_bytes(b"optimiser state: not stored")
    abl = [_record(o, t, k, 100.0, base + k)
           for o, base in (("LAMDE", 10.0), ("LAMDE-F", 40.0), ("LAMDE-R", 20.0))
           for t in ("T1", "T2") for k in range(3)]
    abl_dir = _write(tmp_path / "runs" / "abl", abl, {
        "suite": str(tmp_path / "nosuite"), "budget": 100,
        META_KEY: {"reference": "LAMDE", "driver": "python benchmarks/ablations.py --out abl",
                   "variants": {
                       "LAMDE": {"description": "the method", "checkpoint": str(ck)},
                       "LAMDE-F": {"description": "fixed length", "checkpoint": str(ck)},
                       "LAMDE-R": {"description": "random pairs", "checkpoint": None}}}})
    rates = {"de-lamde": {20: 0.8, 100: 0.6}, "de-lamde-fixedlen": {20: 0.9, 100: 0.0}}
    im = [_imax_record(o, t, k, i, rates[o][i] + 0.01 * k)
          for k in range(2) for t in ("T1", "T2") for i in (20, 100) for o in rates]
    im.append(_imax_record("de-lamde", "T1", 2, 20, 0.0))  # an unfinished run index
    imax_dir = _write(tmp_path / "runs" / "imax", im, {
        "budget": 100, "commands": [{"command": "lamde-mission bench --i-max 20 100"}]})
    return {"main": main_dir, "abl": abl_dir, "imax": imax_dir, "ck": ck}


def test_complete_runs_keep_the_runs_every_cell_has() -> None:
    recs = [_imax_record(o, t, k, 20, 0.5) for k in range(3) for t in ("T1", "T2")
            for o in ("a", "b")]
    recs = [r for r in recs if not (r["run"] == 2 and r["task"] == "T2")]
    kept, left = complete_runs(recs)
    assert left == [2] and {r["run"] for r in kept} == {0, 1} and len(kept) == 8
    # the cells are the product of the values seen: records of a on T1 and b on T2 imply
    # the cells (a, T2) and (b, T1), which run 0 lacks
    partial = [_imax_record("a", "T1", 0, 20, 0.5), _imax_record("b", "T2", 0, 20, 0.5)]
    assert complete_runs(partial) == ([], [0])
    assert complete_runs([]) == ([], [])


def test_slim_record_keeps_what_the_tables_read() -> None:
    full = _imax_record("de-lamde", "T1", 0, 40, 0.25)
    slim = slim_record(full)
    assert set(slim) <= {*SLIM_FIELDS, "history"}
    assert "x" not in slim and "hover_points" not in slim and "map_sha256" not in slim
    assert slim["history"] == {"evaluations": [10], "best_f": [100.0], "best_phi": [0.0]}
    assert imax_table([slim]) == imax_table([full])
    assert "history" not in slim_record({k: v for k, v in full.items() if k != "history"})


@pytest.mark.slow  # measured 1.9 s on a loaded machine (default suite <= 5 min)
def test_report_sections_from_study_folders_and_their_slim_copies(
        studies: dict[str, Path], tmp_path: Path) -> None:
    md = tmp_path / "docs" / "results.md"
    assert main(["report", str(studies["main"]), "-o", str(md), "--no-limits", "--reference",
                 "de-lamde", "--imax", str(studies["imax"]), "--ablations",
                 str(studies["abl"]), "--mkdir"]) == 0
    text = md.read_text()
    command = text.split("Report produced by:")[1].splitlines()[2]
    assert f"--imax {studies['imax']} --ablations {studies['abl']}" in command
    abl = text[text.index("## Ablations"):text.index("## I_max study")]
    assert "python benchmarks/ablations.py --out abl" in abl
    assert "| Task | LAMDE-F | LAMDE-R | LAMDE (ref) |" in abl
    assert "| T1 | 41.0 ± 0.8 + | 21.0 ± 0.8 + | **11.0 ± 0.8** |" in abl
    assert "| +/~/- | 2/0/0 | 2/0/0 | (reference) |" in abl
    assert "| LAMDE | 6 | 6 (100 %) | 2/2 | 0.10 |" in abl
    assert "| LAMDE | the method | 2 epoch(s), 20 s |" in abl
    assert "| LAMDE-F | 6 | 0.4100 ± 0.0082 | 0.4100 | + |" in abl
    assert "below, per start mode" in abl
    imax = text[text.index("## I_max study"):]
    assert "lamde-mission bench --i-max 20 100" in imax
    assert "runs 2 exist for some cells only and are left out" in imax
    assert "2 task(s) (T1, T2), 2 run(s) each" in imax
    assert "| de-lamde | 0.81 ± 0.01 (n 4) | 0.60 ± 0.01 (n 4) |" in imax
    assert "| de-lamde-fixedlen | 0.91 ± 0.01 (n 4) | 0.01 ± 0.01 (n 4) |" in imax
    # the final scores at each I_max against the report's reference (2 runs: never significant)
    assert "against **de-lamde**" in imax
    assert "| de-lamde (ref) | best on 0/2 | best on 2/2 |" in imax
    assert "| de-lamde-fixedlen | best on 2/2, +/~/- 0/2/0 | best on 0/2, +/~/- 0/2/0 |" in imax
    for png in re.findall(r"!\[[^]]*\]\(([^)]+)\)", abl + imax):
        assert (md.parent / png).read_bytes()[:4] == b"\x89PNG"
    assert text.index("## Protocol: init uniform") < text.index("## Ablations")

    # the slim copies give the same tables; the checkpoint travels, its optimiser state not
    slim = {k: tmp_path / "stored" / k for k in ("abl", "imax")}
    assert store_runs(studies["abl"], slim["abl"]) == 18
    assert store_runs(studies["imax"], slim["imax"]) == 17
    assert (slim["abl"] / RESULTS_FILE).stat().st_size < (
        studies["abl"] / RESULTS_FILE).stat().st_size
    meta = json.loads((slim["abl"] / "meta.json").read_text())
    assert meta[META_KEY]["variants"]["LAMDE"]["checkpoint"] == (
        slim["abl"] / "train" / "LAMDE").as_posix()
    assert (slim["abl"] / "train" / "LAMDE" / "weights.npz").read_bytes() == b"weights"
    assert not (slim["abl"] / "train" / "LAMDE" / "state.pt").exists()
    assert meta["stored"]["from"] == studies["abl"].as_posix()
    again = study_sections(md, tmp_path / "fig2", imax=slim["imax"], ablations=slim["abl"])
    before = study_sections(md, tmp_path / "fig2", imax=studies["imax"],
                            ablations=studies["abl"])

    def tables(lines: list[str]) -> list[str]:
        return [ln for ln in lines if ln.startswith("|")]

    assert tables(again) == tables(before)
    assert any("slim copy of" in ln for ln in again)
    # storing the same runs again gives the same bytes
    first = (slim["imax"] / RESULTS_FILE).read_bytes()
    store_runs(studies["imax"], slim["imax"])
    assert (slim["imax"] / RESULTS_FILE).read_bytes() == first
    assert len(read_records(slim["imax"] / RESULTS_FILE).records) == 17


@pytest.mark.slow  # measured 2.5 s on a loaded machine (default suite <= 5 min)
def test_study_folders_refused_with_one_clear_line(studies: dict[str, Path], tmp_path: Path,
                                                   capsys: pytest.CaptureFixture) -> None:
    md = tmp_path / "r.md"
    base = ["report", str(studies["main"]), "-o", str(md), "--no-limits"]
    assert main([*base, "--imax", str(tmp_path / "none")]) == 2
    assert "--imax" in capsys.readouterr().err and not md.exists()
    assert main([*base, "--ablations", str(studies["imax"])]) == 2  # no ablation entry
    assert "no 'ablation' entry" in capsys.readouterr().err and not md.exists()
    assert main([*base, "--imax", str(studies["main"])]) == 2  # no I_max override
    assert "no run overrides I_max" in capsys.readouterr().err
    with pytest.raises(ValueError, match="no results"):
        store_runs(tmp_path / "none", tmp_path / "x")
    with pytest.raises(ValueError, match="is the source folder"):
        store_runs(studies["abl"], studies["abl"])
    build_report(studies["main"], md, reference="de-lamde", limits=False)
    assert "## Ablations" not in md.read_text() and "## I_max" not in md.read_text()


def test_store_runs_script(studies: dict[str, Path], tmp_path: Path) -> None:
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "benchmarks/store_runs.py", str(studies["imax"]),
                        str(tmp_path / "s")], cwd=ROOT, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0 and "stored 17 run(s)" in r.stdout
    r = subprocess.run([sys.executable, "benchmarks/store_runs.py", str(tmp_path / "none"),
                        str(tmp_path / "s2")], cwd=ROOT, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 2 and r.stderr.startswith("error: store: no results")

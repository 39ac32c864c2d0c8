"""`lamde-mission report` reads a results folder whose records are stored gzip-compressed
(`results.jsonl.gz`, as docs/ keeps them), as it reads a plain one."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from tests.conftest import ROOT, run_cli


@pytest.mark.slow  # 7.7 s measured in the default suite
def test_report_reads_a_compressed_results_folder(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    shutil.copytree(ROOT / "docs" / "reduced" / "runs", runs)
    assert (runs / "results.jsonl.gz").exists() and not (runs / "results.jsonl").exists()
    out = tmp_path / "report.md"
    r = run_cli("report", runs, "-o", out, "--no-limits")
    assert r.returncode == 0, r.stderr
    assert out.read_text().strip()
    empty = tmp_path / "empty"
    empty.mkdir()
    r = run_cli("report", empty, "-o", tmp_path / "x.md")
    assert r.returncode == 2 and "no results.jsonl" in r.stderr

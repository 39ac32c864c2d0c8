"""docs/scaling.md's large-suite quality table is what its stored runs give (issue 31)."""

from __future__ import annotations

import re
import statistics

from planner_core.bench._io import read_jsonl
from tests.conftest import ROOT

RECORDS = ROOT / "docs" / "scaling" / "large-suite-seeded.jsonl.gz"
#: one row: map, planner feasible, mean f, gap %, s, engineering feasible, mean f, s, p
ROW = re.compile(r"^\| (L\d\d) \| (\d+)/(\d+) \| ([\d.]+) \| [\d.]+ \| ([\d.]+) \| (\d+)/(\d+) \| "
                 r"([\d.]+) \| ([\d.]+) \| [\d.]+ \|$", re.M)  # fmt: skip


def test_large_suite_table_is_what_the_stored_runs_give() -> None:
    text = (ROOT / "docs" / "scaling.md").read_text(encoding="utf-8")
    rows = ROW.findall(text)
    assert len(rows) == 8
    runs = read_jsonl(RECORDS)
    for task, pf, pn, pmean, pwall, ef, en, emean, ewall in rows:
        for opt, feas, n, mean, wall in (("planner", pf, pn, pmean, pwall),
                                         ("engineering", ef, en, emean, ewall)):  # fmt: skip
            rs = [r for r in runs if r["optimiser"] == opt and r["task"] == task]
            assert len(rs) == int(n) and sum(r["feasible"] for r in rs) == int(feas)
            assert f"{statistics.mean(r['f'] for r in rs):.1f}" == mean, (task, opt)
            assert f"{statistics.mean(r['wall_s'] for r in rs):.1f}" == wall, (task, opt)

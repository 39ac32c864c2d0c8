"""check and plan print the first findings of one kind about sensors in full and the rest on
one line (a 400 s battery on a 10 km map made one long CANNOT line per sensor)."""

from __future__ import annotations

import json

from lamde_mission.cli import main
from lamde_mission.commands.check import SHOWN_PER_KIND, finding_lines
from planner_core.model.diagnose import Finding
from tests.conftest import ROOT


def _f(kind: str, j: int, fatal: bool = True) -> Finding:
    return Finding(kind, fatal, f"sensor 's{j}': {kind} message", f"s{j}")


def test_beyond_the_first_few_one_line_names_the_rest():
    n = SHOWN_PER_KIND + 4
    fs = [_f("ENERGY_RANGE", j) for j in range(n)] + [_f("ENERGY_SPLIT", n, False)]
    fs += [Finding("VEHICLES", True, "fleet.uavs: no sensor named here")]
    lines = finding_lines(fs)
    full = [line for _, line in lines if "ENERGY_RANGE message" in line]
    assert len(full) == SHOWN_PER_KIND
    assert (False, f"sensor 's{n}': ENERGY_SPLIT message") in lines
    assert (True, "fleet.uavs: no sensor named here") in lines
    rest = ", ".join(f"'s{j}'" for j in range(SHOWN_PER_KIND, n))
    assert lines[-1] == (True, f"4 more sensors alike (ENERGY_RANGE): {rest} "
                               "(`lamde-mission check --json` gives each one's line)")
    # one more than the few is printed in full, not as "1 more sensor alike"
    six = finding_lines([_f("ENERGY_RANGE", j) for j in range(SHOWN_PER_KIND + 1)])
    assert len(six) == SHOWN_PER_KIND + 1 and not any("alike" in line for _, line in six)


def test_check_on_a_battery_too_small_for_the_map(tmp_path, capsys):
    doc = json.loads((ROOT / "examples" / "maps" / "large" / "L01.json").read_text())
    doc["uav"]["endurance_s"] = 400.0
    path = tmp_path / "small-battery.json"
    path.write_text(json.dumps(doc))
    assert main(["check", str(path), "--json"]) == 1
    every = [f for f in json.loads(capsys.readouterr().out)["diagnosis"]
             if f["kind"] == "ENERGY_RANGE"]
    assert len(every) > SHOWN_PER_KIND + 1
    assert main(["check", str(path)]) == 1
    out = capsys.readouterr().out
    assert out.count("no sortie can collect any of its data") == SHOWN_PER_KIND
    rest = [f["sensor"] for f in every[SHOWN_PER_KIND:]]
    assert (f"CANNOT  {len(rest)} more sensors alike (ENERGY_RANGE): "
            + ", ".join(f"'{x}'" for x in rest[:SHOWN_PER_KIND]) + ", ...") in out

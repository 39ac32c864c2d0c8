"""The one defaults table: its readers agree with it, bad values name the field, the README
table is rendered from it."""

from __future__ import annotations

import ast
import inspect
import re
import subprocess
import sys

import numpy as np
import pytest

import lamde_mission
from planner_core import defaults as D
from planner_core.learning.env import OptimizationEnv
from planner_core.model.mapio import MapFile
from planner_core.search.de import loop as de_loop
from planner_core.search.de.configurators import _REGISTRY as CONFIGURATOR_REGISTRY
from planner_core.search.de.operators import N_DONORS
from tests.conftest import MAPS, ROOT, one_line_error, run_cli


def test_module_imports_only_the_standard_library() -> None:
    tree = ast.parse(inspect.getsource(D))
    names = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import)
             for a in n.names}
    names |= {n.module.split(".")[0] for n in ast.walk(tree)
              if isinstance(n, ast.ImportFrom) and n.module}
    assert names <= set(sys.stdlib_module_names) | {"__future__"}, names
    # and the CLI can read it without loading numpy (a fresh process)
    code = "import planner_core.defaults, sys; print('numpy' in sys.modules)"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert r.stdout.strip() == "False", r.stderr


def test_every_entry_is_complete_and_its_default_is_valid() -> None:
    for table in (D.DEFAULTS, D.MAP_DEFAULTS, D.MAP_CHOICES, D.MAP_LISTS):
        for name, d in table.items():
            assert d.name == name and d.meaning and d.valid
            assert d.check(d.value) == d.value  # a default lies in its own valid range
    assert D.check_run_args(population=D.POPULATION, budget=D.BUDGET,
                            configurator=D.CONFIGURATOR) is None


def test_the_readers_use_the_table() -> None:
    assert N_DONORS + 1 == D.MIN_POPULATION  # rand/2 needs five donors besides the target
    assert set(CONFIGURATOR_REGISTRY) == set(D.CONFIGURATORS)
    sig = inspect.signature(lamde_mission.plan).parameters
    assert sig["population"].default == D.POPULATION == 100
    assert sig["budget"].default == D.BUDGET == 10_000
    assert sig["configurator"].default == D.CONFIGURATOR == "adaptive"
    run_sig = inspect.signature(de_loop.run).parameters
    assert run_sig["population"].default == D.POPULATION and run_sig["budget"].default == D.BUDGET
    env = OptimizationEnv()
    assert (env.population, env.budget, env.eta, env.delta) == (D.POPULATION, D.BUDGET, D.ETA,
                                                                  D.DELTA)
    from planner_core.bench.baselines import REGISTRY
    from planner_core.model.formulas import PENALTY_FACTOR
    from planner_core.suite import SUITE_SEED

    assert PENALTY_FACTOR == D.SCORE_FACTOR == 10.0 and SUITE_SEED == D.SUITE_SEED == 2025
    assert {n for n in REGISTRY if n.startswith("de-")} == {
        f"de-{c}{s}" for c in D.CONFIGURATORS for s in ("", "-fixedlen")}
    from lamde_mission.api import CONFIGURATORS

    assert CONFIGURATORS == D.CONFIGURATORS


def test_map_loader_defaults_come_from_the_table() -> None:
    schema = MapFile.model_json_schema()["$defs"]
    for path, d in D.MAP_DEFAULTS.items():
        section, field = path.rsplit(".", 1)
        model = {"uav": "Uav", "radio": "Radio", "objective": "Objective",
                 "safety": "Safety", "uav.battery": "Battery", "uav.power": "Power",
                 "fleet": "Fleet"}[section]
        assert schema[model]["properties"][field].get("default") == d.value, path
    for path, d in {**D.MAP_CHOICES, **D.MAP_LISTS}.items():
        section, field = path.split(".")
        model = {"radio": "Radio", "objective": "Objective", "fleet": "Fleet"}[section]
        assert schema[model]["properties"][field].get("default") == d.value, path


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"population": 5}, "population"),
        ({"population": 6.0}, "population"),
        ({"population": True}, "population"),
        ({"population": 20, "budget": 19}, "budget"),
        ({"configurator": "policy-v0"}, "configurator"),
    ],
)
def test_api_names_the_bad_field(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=rf"^{field}: must be ") as exc:
        lamde_mission.plan(MAPS / "tiny.json", **kwargs)
    assert "\n" not in str(exc.value)


HUGE = 99999999999999999999999  # the review's: accepted, and the run never ended


def test_a_budget_above_max_budget_is_refused_by_every_entry_point(
    tmp_path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A budget has an upper bound, MAX_BUDGET (it had none: `plan --budget 1e23` ran without
    end): the API, PlanConfig, plan_fleet's sortie_budget, and `plan --budget`,
    `plan --sortie-budget` (a fleet map), `bench --budget` and `train --budget` all refuse one
    above it with the one message of `check_budget`, naming the option and the range, before
    any work (the planners and the map reader are tripwires here); MAX_BUDGET itself passes."""
    import lamde_mission.api
    import lamde_mission.commands._common
    from lamde_mission.cli import main
    from planner_core.pipeline import PlanConfig

    rng = f"[population (100), {D.MAX_BUDGET}]"
    assert D.check_budget(D.MAX_BUDGET, 100) == D.MAX_BUDGET
    assert PlanConfig(budget=D.MAX_BUDGET).budget == D.MAX_BUDGET
    for bad in (D.MAX_BUDGET + 1, HUGE):
        with pytest.raises(ValueError) as exc:
            D.check_budget(bad, 100)
        assert str(exc.value) == f"budget: must be an integer in {rng}, got {bad}"
        with pytest.raises(ValueError, match=r"^budget: must be an integer in \[population"):
            PlanConfig(budget=bad)
        with pytest.raises(ValueError, match=rf"^budget: .*{D.MAX_BUDGET}\], got {bad}$"):
            lamde_mission.plan(MAPS / "tiny.json", budget=bad)
        with pytest.raises(ValueError, match=rf"^sortie_budget: .*{D.MAX_BUDGET}\], got {bad}$"):
            lamde_mission.api.plan_fleet(MAPS / "fleet-demo.json", sortie_budget=bad)
    with pytest.raises(ValueError, match=r"^budget: must be an integer in \[1, 10000000\]"):
        D.check_budget(0, 1, least_name=None)

    def tripwire(*_a: object, **_k: object) -> None:
        raise AssertionError("reached past the budget check")

    monkeypatch.setattr(lamde_mission.api, "plan", tripwire)
    monkeypatch.setattr(lamde_mission.api, "plan_fleet", tripwire)
    monkeypatch.setattr(lamde_mission.commands._common, "load_map_or_fail", tripwire)
    monkeypatch.chdir(tmp_path)
    for argv, line in (
        (["plan", str(MAPS / "small-demo.json"), "-o", "x.plan", "--budget", str(HUGE)],
         f"lamde-mission plan: --budget: must be an integer in {rng}, got {HUGE}"),
        (["plan", str(MAPS / "fleet-demo.json"), "-o", "d", "--budget", str(HUGE)],
         f"lamde-mission plan: --budget: must be an integer in {rng}, got {HUGE}"),
        (["plan", str(MAPS / "fleet-demo.json"), "-o", "d", "--sortie-budget", str(HUGE)],
         f"lamde-mission plan: --sortie-budget: must be an integer in {rng}, got {HUGE}"),
        (["bench", "--budget", str(HUGE), "--out", "b"],
         f"lamde-mission bench: --budget: must be an integer in {rng}, got {HUGE}"),
        (["train", "-o", "t.pt", "--budget", str(HUGE)],
         "lamde-mission train: --budget: must be an integer in [population (50), "
         f"{D.MAX_BUDGET}], got {HUGE}"),
    ):
        capsys.readouterr()
        assert main(argv) == 2, argv
        assert capsys.readouterr().err.splitlines() == [line]
    assert list(tmp_path.iterdir()) == []


def test_numpy_integers_are_accepted() -> None:
    D.check_run_args(population=np.int64(6), budget=np.int32(12), configurator="fixed")
    D.check("seed", np.uint8(3))


@pytest.mark.slow  # measured 1.2 s on a loaded machine (default suite <= 5 min)
def test_cli_population_5_is_one_line_and_exit_2(tmp_path) -> None:
    out = tmp_path / "x.plan"
    r = run_cli("plan", MAPS / "small-demo.json", "-o", out, "--population", "5")
    line = one_line_error(r)
    assert "--population" in line and str(D.MIN_POPULATION) in line
    assert not out.exists()


def test_readme_defaults_table_is_rendered_from_the_module() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    m = re.search(r"<!-- defaults:begin -->\n(.*?)<!-- defaults:end -->", readme, re.S)
    assert m, "README.md lost its generated defaults table markers"
    assert m.group(1) == D.render_markdown(), (
        "README's defaults table is stale: regenerate it with "
        "`python -m planner_core.defaults README.md`")


def test_update_readme_rewrites_only_the_table(tmp_path) -> None:
    doc = tmp_path / "R.md"
    doc.write_text("intro\n<!-- defaults:begin -->\nold\n<!-- defaults:end -->\nrest\n")
    assert D.update_readme(str(doc)) is True
    assert doc.read_text() == ("intro\n<!-- defaults:begin -->\n" + D.render_markdown()
                               + "<!-- defaults:end -->\nrest\n")
    assert D.update_readme(str(doc)) is False
    (tmp_path / "bare.md").write_text("no table\n")
    with pytest.raises(ValueError, match="markers"):
        D.update_readme(str(tmp_path / "bare.md"))


def test_a_population_above_max_population_is_refused_before_any_work(tmp_path, capsys
                                                                      ) -> None:
    """The population had no upper bound but the budget's: `--population 10000000` would ask
    for (N, d) arrays of tens of GB. It is now at most MAX_POPULATION, checked with the other
    run settings (PlanConfig, the API, `plan --population`), one line naming it."""
    from lamde_mission.cli import main
    from planner_core.pipeline import PlanConfig

    assert PlanConfig(population=D.MAX_POPULATION, budget=D.MAX_POPULATION).population \
        == D.MAX_POPULATION
    msg = f"population: must be an integer in [{D.MIN_POPULATION}, {D.MAX_POPULATION}]"
    bad = D.MAX_POPULATION + 1
    with pytest.raises(ValueError, match=re.escape(f"{msg}, got {bad}")):
        PlanConfig(population=bad, budget=D.MAX_BUDGET)
    with pytest.raises(ValueError, match=re.escape(msg)):
        import lamde_mission

        lamde_mission.plan(MAPS / "tiny.json", population=bad, budget=D.MAX_BUDGET)
    status = main(["plan", str(MAPS / "tiny.json"), "-o", str(tmp_path / "x.plan"),
                   "--population", str(bad), "--budget", str(D.MAX_BUDGET)])  # fmt: skip
    err = capsys.readouterr().err
    assert status == 2 and len(err.splitlines()) == 1 and "population" in err, err
    assert not list(tmp_path.iterdir())


def test_number_text_rounds_to_significant_digits_in_plain_digits() -> None:
    """`check` printed "7.2e+04 Wh usable (2.56e+04 min ...)" with `:.4g` and `:.3g`: the same
    rounding, written out."""
    from planner_core.defaults import number_text

    assert [number_text(v, d) for v, d in [(72000.0, 4), (25639.5, 3), (8.8333, 3),
                                           (0.0123456, 3), (1.23456e-7, 3), (0.0, 3),
                                           (-1234567.0, 2), (1e17, 3)]] == [
        "72000", "25600", "8.83", "0.0123", "1.23e-07", "0", "-1200000", "1e+17"]
    assert number_text(25639.5) == "25639.5" and number_text(90000) == "90000"  # as before

"""The figures the manual quotes from the energy model (docs/energy.md, the vertical phases of
docs/sorties.md) are what the code computes now, and the energy page's Python example prints
what its comments say. Each figure is recomputed here (milliseconds) and looked for in the page
as the page writes it, so a change to the model that moves a quoted figure fails here until the
page is corrected. (The fleet-demo objective docs/sorties.md quotes takes a minute of planning
at the default budgets, too long for this suite.)"""

from __future__ import annotations

import re

import pytest
from scipy.optimize import minimize_scalar

from planner_core import defaults as D
from planner_core import load_map
from planner_core.fleet.split import SHARE_MAX
from planner_core.model import energy as E
from planner_core.model.formulas import flight_time
from tests.conftest import MAPS, ROOT


def _page(name: str) -> str:
    """The page's text with every run of white space (line breaks included) one space."""
    return " ".join((ROOT / "docs" / name).read_text(encoding="utf-8").split())


def _quoted(page: str, name: str, figures: list[str]) -> None:
    missing = [f for f in figures if f not in page]
    assert not missing, f"docs/{name} no longer says (the model gives now): {missing}"


def _argmin(f, hi: float) -> tuple[float, float]:
    r = minimize_scalar(f, bounds=(0.5, hi), method="bounded", options={"xatol": 1e-9})
    return float(r.x), float(r.fun)


def _uav(name: str) -> float:
    return float(D.MAP_DEFAULTS[f"uav.{name}"].value)


def test_energy_page_figures_are_the_models() -> None:
    page = _page("energy.md")
    v_max, accel, h = _uav("max_speed"), _uav("acceleration"), _uav("altitude")
    up, down = _uav("climb_speed"), _uav("descent_speed")
    p0 = E.hover_power_w()

    def p(v: float) -> float:
        return float(E.power_w(v))

    v_p, p_min = _argmin(p, 40.0)
    v_jm, jm_min = _argmin(lambda v: p(v) / v, 40.0)
    battery = E.battery_energy_wh(None, 1500.0)
    e_vert = E.vertical_energy_wh(h, up, down, accel)
    e_fast = E.vertical_energy_wh(h, v_max, v_max, accel)
    bound = E.least_energy_per_metre_wh(v_max) * E.J_PER_WH
    _quoted(page, "energy.md", [
        f"1500 s x {p0:.2f} W = {battery:.1f} Wh",
        f"{E.usable_energy_wh(battery, 0.2):.1f} Wh are usable with the default 20 % reserve",
        f"P(0) = P0 + Pi = {p0:.2f} W",
        f"least near {v_p:.1f} m/s ({p_min:.1f} W)",
        f"P(20 m/s) = {p(20.0):.1f} W", f"P(30 m/s) = {p(30.0):.1f} W",
        f"least at {v_jm:.1f} m/s ({jm_min:.2f} J/m)",
        f"default cruise speed of {v_max:.0f} m/s ({p(v_max) / v_max:.2f} J/m)",
        f"a 1 km leg costs {float(E.leg_energy_wh(1000.0, v_max, accel)):.3f} Wh "
        f"({float(flight_time(1000.0, v_max, accel)):.0f} s)",
        f"ten minutes of hover {float(E.hover_energy_wh(600.0)):.2f} Wh",
        # as `verify` prints the take-off and the landing (lamde_mission/commands/verify.py)
        f"at {h:.0f} m, {float(flight_time(h, up, accel)):.1f} s up and "
        f"{float(flight_time(h, down, accel)):.1f} s down, {e_vert:.2f} Wh",
        f"({v_max:.0f} m/s: {E.vertical_time_s(h, v_max, v_max, accel):.0f} s, {e_fast:.2f} Wh",
        f"understated every sortie by ~{e_vert - e_fast:.1f} Wh",
        f"spends {p(12.0) / 12.0:.2f} J/m instead of {p(v_max) / v_max:.2f} at {v_max:.0f} m/s",
        f"{bound:.2f} J/m at the defaults, {100 * (1 - bound / jm_min):.2f} % under the true "
        f"{jm_min:.2f}",
        f"({SHARE_MAX}, `planner_core.fleet.split.SHARE_MAX`)",
    ])  # fmt: skip


def test_sorties_page_vertical_phase_figures_are_the_models() -> None:
    """The vertical take-off and landing the 25-minute battery maps' sorties pay
    (examples/maps/L01-25min.json: the benchmark's battery map), against the horizontal v_max
    they were flown at before."""
    page = _page("sorties.md")
    m = load_map(MAPS / "L01-25min.json")
    u = m.spec.uav
    t_vert = E.vertical_time_s(u.altitude, u.climb_speed, u.descent_speed, u.acceleration)
    e_vert = E.vertical_energy_wh(u.altitude, u.climb_speed, u.descent_speed, u.acceleration)
    t_fast = E.vertical_time_s(u.altitude, u.max_speed, u.max_speed, u.acceleration)
    e_fast = E.vertical_energy_wh(u.altitude, u.max_speed, u.max_speed, u.acceleration)
    usable = m.usable_energy_wh
    _quoted(page, "sorties.md", [
        f"({u.climb_speed:g} and {u.descent_speed:g} m/s by default: {t_vert:.1f} s and "
        f"{e_vert:.2f} Wh at {u.altitude:.0f} m",
        f"({t_fast:.0f} s and {e_fast:.2f} Wh)",
        f"{e_vert - e_fast:.2f} Wh ({100 * (e_vert - e_fast) / usable:.0f} % of the "
        f"{usable:.2f} Wh usable)",
        f"each sortie costs {t_vert - t_fast:.0f} s more",
        f"its {m.swap_s:.0f} s swap and {t_vert:.0f} s of take-off and landing",
        f"a sortie saved is worth {m.swap_s + t_vert:.0f} s",
        f"t_vert {t_vert:.1f} s and E_vert {e_vert:.2f} Wh, where they were {t_fast:.0f} s and "
        f"{e_fast:.2f} Wh",
        f"every LB rose by {t_vert - t_fast:.0f} s a sortie",
        f"{usable:.2f} Wh usable with the 20 % reserve",
    ])  # fmt: skip


def _print_lines(code: str) -> list[tuple[str, str]]:
    """(the printed expression, the figure its comment gives) of each commented `print(...)`."""
    out = []
    for line in code.splitlines():
        m = re.match(r"print\((.*)\)\s*#\s*~?([-\d.]+)", line)
        if m:
            out.append((m.group(1), m.group(2)))
    return out


def test_energy_page_python_example_prints_what_its_comments_say(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The page's `From Python` block, run as pasted in the repository root: each printed
    value, rounded as its comment writes it, is the comment's figure (it said 10.30 Wh for a
    sortie after the vertical phases had made it 15.96)."""
    (code,) = re.findall(r"```python\n(.*?)```",
                         (ROOT / "docs" / "energy.md").read_text(encoding="utf-8"), re.S)
    expected = _print_lines(code)
    assert len(expected) == 3, code
    monkeypatch.chdir(ROOT)
    exec(compile(code, "docs/energy.md", "exec"), {"__name__": "docs_energy_example"})
    printed = capsys.readouterr().out.split()
    assert len(printed) == len(expected), printed
    for (expr, figure), value in zip(expected, printed, strict=True):
        decimals = len(figure.partition(".")[2])
        assert f"{float(value):.{decimals}f}" == figure, (
            f"docs/energy.md: print({expr}) prints {value}, its comment says {figure}")

"""The public planning call: determinism, the Plan value, options, argument errors."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import lamde_mission
from lamde_mission import Plan
from planner_core import Problem

SMALL = {
    "name": "api-small",
    "area": {"width": 2000, "height": 2000},
    "start": [100, 100],
    "end": [1900, 1900],
    "sensors": [
        {"id": f"s{i}", "x": x, "y": y}
        for i, (x, y) in enumerate([(500, 400), (1500, 600), (900, 1500), (1700, 1700)])
    ],
    "obstacles": {"circles": [{"x": 1000, "y": 1000, "radius": 90}]},
    "uav": {"max_hover_points": 6},
}


@pytest.fixture(scope="module")
def small_plan() -> Plan:
    return lamde_mission.plan(SMALL, seed=3, budget=3000, population=50)


def test_plan_is_feasible_and_consistent(small_plan: Plan) -> None:
    p = small_plan
    assert p.feasible and p.phi == 0.0
    assert p.evaluations <= 3000
    assert p.hover_points.shape == (p.n_hover, 2)
    # the recorded breakdown is the model's own verdict on the recorded points and times
    prob = Problem(SMALL)
    b = prob.breakdown(prob.encode(p.hover_points, p.hover_times))
    assert b["f"] == pytest.approx(p.f, rel=1e-12) and b["phi"] == p.phi
    assert set(p.history) == {"evaluations", "best_f", "best_phi"}
    assert np.all(np.diff(p.history["evaluations"]) > 0)
    assert p.history["best_f"][-1] == p.f  # the trace ends at the plan returned
    assert p.polish is not None and p.polish["f_after"] <= p.polish["f_before"] + 1e-9
    # every stage that ran is recorded; their evaluations are the plan's, counted once
    names = [s.name for s in p.stages]
    assert names[:4] == ["constructive", "start descents", "de", "polish"]
    assert sum(s.evaluations for s in p.stages) == p.evaluations
    assert all(s.evaluations <= s.allotted for s in p.stages)
    # the incumbent never gets worse from one stage to the next, and ends at the plan
    for a, b in zip(p.stages, p.stages[1:], strict=False):
        assert (a.f_after, a.phi_after) == (b.f_before, b.phi_before)
        assert b.phi_after < b.phi_before or (b.phi_after == b.phi_before
                                              and b.f_after <= b.f_before)
    assert p.stages[-1].f_after == p.f
    assert set(p.timings) == {"compile", "setup", "planning", "evaluation", "total"}
    parts = p.timings["compile"] + p.timings["setup"] + p.timings["planning"]
    assert parts <= p.timings["total"] + 1e-9
    assert p.config["budget"] == 3000 and p.config["population"] == 50 and p.stopped == ""


def test_plan_is_immutable(small_plan: Plan) -> None:
    with pytest.raises(ValueError):
        small_plan.hover_points[0, 0] = 1.0
    with pytest.raises(AttributeError):
        small_plan.f = 0.0  # type: ignore[misc]


@pytest.mark.slow  # measured 8 s (issue 35: default suite <= 5 min)
def test_same_seed_same_plan_bit_for_bit(small_plan: Plan) -> None:
    again = lamde_mission.plan(SMALL, seed=3, budget=3000, population=50)
    assert again.same_as(small_plan)
    other = lamde_mission.plan(SMALL, seed=4, budget=3000, population=50)
    assert not other.same_as(small_plan)


@pytest.mark.slow  # measured 18 s (issue 35: default suite <= 5 min)
def test_same_seed_same_plan_in_a_fresh_process(small_plan: Plan) -> None:
    """No hidden process state (caches, reused generators) changes a plan."""
    code = (
        "import json, sys, lamde_mission; "
        "p = lamde_mission.plan(json.loads(sys.argv[1]), seed=3, budget=3000, population=50); "
        "print(json.dumps(p.to_dict()))"
    )
    r = subprocess.run([sys.executable, "-c", code, json.dumps(SMALL)], capture_output=True,
                       text=True, timeout=300)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert Plan.from_dict(json.loads(r.stdout)).same_as(small_plan)


def test_to_dict_from_dict_round_trip(small_plan: Plan) -> None:
    d = json.loads(json.dumps(small_plan.to_dict()))
    back = Plan.from_dict(d)
    assert back.same_as(small_plan)
    assert back.to_dict() == d


@pytest.mark.slow  # measured 7 s (issue 35: default suite <= 5 min)
def test_options(tmp_path) -> None:
    path = tmp_path / "m.json"
    path.write_text(json.dumps(SMALL))
    raw = lamde_mission.plan(path, seed=0, budget=600, population=20, polish=False,
                             configurator="fixed")
    assert raw.polish is None and raw.configurator == "fixed"
    fixed = lamde_mission.plan(SMALL, seed=0, budget=600, population=20, variable_length=False)
    assert fixed.n_hover == 6 and not fixed.variable_length


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [({"budget": 10}, "budget"), ({"population": 2}, "population"),
     ({"configurator": "magic"}, "configurator")],
)
def test_bad_arguments_name_the_field(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=f"^{field}:"):
        lamde_mission.plan(SMALL, **kwargs)


@pytest.mark.slow  # measured 6 s (issue 35: default suite <= 5 min)
def test_kernel_compilation_is_timed_apart_from_the_optimisation():
    """The first plan in a process compiles (or loads) the kernels in a warm-up run on a tiny
    built-in map, reported as timings['compile'] and announced through `on_compile`; later
    calls have none, and both give the same plan."""
    from lamde_mission import api
    from planner_core.pipeline import warmup
    from tests.conftest import MAPS

    warmup._WARM.discard("random")
    told: list[int] = []
    a = lamde_mission.plan(MAPS / "tiny.json", seed=3, budget=600, configurator="random",
                           on_compile=lambda: told.append(1))
    b = lamde_mission.plan(MAPS / "tiny.json", seed=3, budget=600, configurator="random",
                           on_compile=lambda: told.append(2))
    assert a.timings["compile"] > 0.0 and b.timings["compile"] == 0.0 and told == [1]
    assert a.timings["planning"] <= a.timings["total"] - a.timings["compile"] + 1e-9
    assert np.array_equal(a.hover_points, b.hover_points) and a.f == b.f
    assert isinstance(api.kernels_cached(), bool)


@pytest.mark.slow  # measured ~5 s: compiles two geometry kernels into an empty cache
def test_kernels_cached_is_false_on_a_first_run_even_after_the_map_loaded(tmp_path) -> None:
    """docs/getting-started.md: the first run says it is compiling. Loading the map compiles
    two geometry kernels first; "any kernel cached" then said "loading" (and looked in the
    package, not in NUMBA_CACHE_DIR)."""
    import os
    from pathlib import Path

    from lamde_mission import api
    from planner_core.pipeline import warmup

    root = Path(__file__).resolve().parents[1]
    code = ("from planner_core import load_map; load_map('examples/maps/small-demo.json'); "
            "from lamde_mission.api import kernels_cached; print(kernels_cached())")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    r = subprocess.run([sys.executable, "-c", code], cwd=root, env=env, capture_output=True,
                       text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "False"
    warmup.warm_up("adaptive")  # this process's cache (the suite's) holds them after a warm-up
    assert api.kernels_cached()


@pytest.mark.slow  # measured 50-90 s: compiles every kernel into an empty cache
def test_the_install_step_leaves_every_kernel_of_a_plan_cached(tmp_path) -> None:
    """`make setup` and `make demo` end with `python -m planner_core.pipeline.warmup`: a fresh
    install's first plan (and first test) compiled the kernels, 50-90 s of a newcomer's first
    `plan` on 2 CPUs. After the step, a new process finds them in the cache and its warm-up
    compiles nothing."""
    import os
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    r = subprocess.run([sys.executable, "-m", "planner_core.pipeline.warmup"], cwd=root,
                       env=env, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("planner kernels compiled or loaded in "), r.stdout
    code = ("from numba.core import event\n"
            "compiled = []\n"
            "class L(event.Listener):\n"
            "    def on_start(self, ev): compiled.append(ev.data['dispatcher'].py_func.__name__)\n"
            "    def on_end(self, ev): pass\n"
            "event.register('numba:compile', L())\n"
            "from lamde_mission.api import kernels_cached\n"
            "from planner_core.pipeline.warmup import warm_up\n"
            "print(kernels_cached()); warm_up(); print(compiled)")
    r = subprocess.run([sys.executable, "-c", code], cwd=root, env=env, capture_output=True,
                       text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["True", "[]"], r.stdout


def test_setup_stages_are_announced_and_the_cli_prints_only_slow_ones() -> None:
    """`on_setup` hears each setup stage (reading the map, the visibility graph and corner-slot
    rule) start and end: on a map at the obstacle limit setup ran for minutes with no output and
    past --time-limit, which does not cut it (it says so). The CLI's `SetupNotice` prints a
    stage's name only once it has run `after` seconds, then the time it took."""
    import io
    import threading

    from lamde_mission.commands.plan import SetupNotice
    from tests.conftest import MAPS

    heard: list[str | None] = []
    lamde_mission.plan(MAPS / "tiny.json", seed=3, budget=600, on_setup=heard.append)
    assert heard[1::2] == [None, None] and len(heard) == 4
    assert "map" in heard[0] and "visibility graph" in heard[2]

    out = io.StringIO()
    quick = SetupNotice(after=60.0, stream=out)
    quick("reading the map")
    quick(None)
    assert out.getvalue() == ""
    slow = SetupNotice(after=0.0, stream=out)
    slow("building the visibility graph")
    for _ in range(200):  # the timer thread's line (no wall-time bound is asserted)
        if out.getvalue():
            break
        threading.Event().wait(0.01)
    slow(None)
    lines = out.getvalue().splitlines()
    assert lines[0] == "setup: building the visibility graph... (not cut by --time-limit)"
    assert lines[1].startswith("setup: done in ") and len(lines) == 2


def shown_at_once(stream=None, tty: bool = False):
    """A `SetupNotice` that shows each stage's name at once, before the stage goes on (no
    race with its timer thread), on a TTY or not."""
    from lamde_mission.commands.plan import SetupNotice

    class Notice(SetupNotice):
        def _tty(self) -> bool:
            return tty

        def __call__(self, name: str | None) -> None:
            super().__call__(name)
            if self._timer is not None:
                self._timer.join()

    return Notice(after=0.0, stream=stream)


def test_the_setup_line_shows_how_far_the_visibility_graph_is() -> None:
    """Issue 31 (progress for every stage longer than a second): the visibility graph's build
    printed its stage's name and then nothing for a minute at 2,000 campus footprints. A
    shown stage's fraction gets a line of its own: off a TTY once past each quarter (as the
    plan's progress bar), on a TTY one line updated in place, at most every `EVERY` s, then
    overwritten by the time taken. Before the name is shown (a quick stage) nothing."""
    import io
    import re

    from lamde_mission.commands.plan import SetupNotice

    steps = (0.1, 0.3, 0.32, 0.6, 0.9, 1.0)
    out = io.StringIO()
    notice = shown_at_once(out)
    notice("building the visibility graph")
    for f in steps:
        notice.fraction("the visibility graph", f)
    notice(None)
    lines = out.getvalue().splitlines()
    assert lines[0] == "setup: building the visibility graph... (not cut by --time-limit)"
    assert [re.sub(r", \d+ s$", "", line) for line in lines[1:4]] == [
        f"setup: the visibility graph {p:>3} %" for p in (30, 60, 90)]
    assert lines[4].startswith("setup: done in ") and len(lines) == 5

    tty = io.StringIO()
    notice = shown_at_once(tty, tty=True)
    notice.EVERY = 0.0
    notice("building the visibility graph")
    for f in steps:
        notice.fraction("the visibility graph", f)
    notice(None)
    name, updates = tty.getvalue().split("\n", 1)
    assert name == "setup: building the visibility graph... (not cut by --time-limit)"
    shown = updates.split("\r")
    assert shown[0] == "" and updates.count("\n") == 1 and updates.endswith("\n")
    assert [re.sub(r", \d+ s *$", "", u) for u in shown[1:-1]] == [
        f"setup: the visibility graph {round(100 * f):>3} %" for f in steps]
    assert shown[-1].startswith("setup: done in ")  # padded over the longer line before
    assert shown[-1] == shown[-1].rstrip().ljust(len(shown[-2])) + "\n"

    tty = io.StringIO()
    notice = shown_at_once(tty, tty=True)
    notice.EVERY = 1e9  # one update (the first) within any run of this test
    notice("building the visibility graph")
    for f in steps:
        notice.fraction("the visibility graph", f)
    assert tty.getvalue().count("\r") == 1 and " 10 %" in tty.getvalue()

    quick = io.StringIO()
    notice = SetupNotice(after=60.0, stream=quick)
    notice("building the visibility graph")
    notice.fraction("the visibility graph", 0.5)
    notice(None)
    assert quick.getvalue() == ""


def test_a_setup_stage_cut_short_ends_its_line_and_claims_no_time() -> None:
    """`close` (the CLI's `finally`, a Ctrl-C or an error in setup): the open TTY line is
    ended, so "lamde-mission: interrupted" starts on its own, and no "setup: done in" is
    printed for a stage that did not finish (the CLI said "done" before the interrupt)."""
    import io

    for tty in (True, False):
        out = io.StringIO()
        notice = shown_at_once(out, tty=tty)
        notice("building the visibility graph")
        notice.fraction("the visibility graph", 0.5)
        notice.close()
        notice.close()
        notice(None)  # ended already: nothing more
        text = out.getvalue()
        assert "done in" not in text and text.endswith("\n")
        assert text.count("\n") == 2  # the name; the 50 % line, ended


def test_plan_tells_the_cli_how_far_the_visibility_graph_is(monkeypatch, tmp_path) -> None:
    """`plan(on_setup_progress=...)` hears ("the visibility graph", f) up to 1.0 from the
    build, and `lamde-mission plan` shows it on its setup line."""
    from lamde_mission.commands import plan as plan_cmd
    from lamde_mission.fuzz import run_cli
    from tests.conftest import MAPS

    heard: list[tuple[str, float]] = []
    lamde_mission.plan(MAPS / "tiny.json", seed=3, budget=600,
                       on_setup_progress=lambda what, f: heard.append((what, f)))  # fmt: skip
    assert heard and heard[-1] == ("the visibility graph", 1.0)
    assert all(w == "the visibility graph" for w, _ in heard)
    notice = type(shown_at_once(tty=True))  # made before SetupNotice is patched
    monkeypatch.setattr(plan_cmd, "SetupNotice", lambda: notice(after=0.0))
    out = run_cli(["plan", str(MAPS / "tiny.json"), "-o", str(tmp_path / "t.plan"),
                   "--seed", "3", "--budget", "600"])  # fmt: skip
    assert out.status == 0, (out.stderr, out.error)
    assert "\rsetup: the visibility graph 100 %, " in out.stderr

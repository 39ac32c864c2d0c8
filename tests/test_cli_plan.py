"""`lamde-mission plan` through a subprocess: exit codes, files written (or not), summary."""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import MAPS, run_cli

DEMO = MAPS / "small-demo.json"


@pytest.mark.slow  # measured 20 s (issue 35: default suite <= 5 min)
def test_plan_writes_plan_plot_report_and_verifies(tmp_path: Path) -> None:
    out, png, rep = tmp_path / "m.plan", tmp_path / "m.png", tmp_path / "r.json"
    r = run_cli("plan", DEMO, "-o", out, "--plot", png, "--report", rep, "--budget", 3000)
    assert r.returncode == 0, r.stderr
    assert "constraints (simulator)" in r.stdout and "C5" in r.stdout
    # progress on stderr, naming the stage running; the summary starts on its own line
    assert "constructive" in r.stderr and "finish" in r.stderr and "evals" in r.stderr
    assert r.stdout.startswith("map 'small-demo'")
    for path in (out, png, rep):  # every file written is reported
        assert f"wrote {path}" in r.stdout.splitlines(), r.stdout
    doc = json.loads(out.read_text())
    assert doc["fileType"] == "Plan" and doc["mission"]["items"]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    report = json.loads(rep.read_text())
    assert report["verdicts"]["passed"] and report["plan"]["feasible"]
    v = run_cli("verify", DEMO, out)
    assert v.returncode == 0, v.stdout + v.stderr


@pytest.mark.slow  # measured 17 s (issue 35: default suite <= 5 min)
def test_plan_same_seed_same_file(tmp_path: Path) -> None:
    a, b = tmp_path / "a.waypoints", tmp_path / "b.waypoints"
    for path in (a, b):
        r = run_cli("plan", DEMO, "-o", path, "--budget", 1500, "--seed", 7, "--quiet")
        assert r.returncode == 0, r.stderr
        assert r.stdout == ""
    assert a.read_text() == b.read_text()
    assert a.read_text().startswith("QGC WPL 110")


@pytest.mark.slow  # measured 25 s (issue 35: default suite <= 5 min)
def test_infeasible_map_writes_nothing_unless_allowed(tmp_path: Path) -> None:
    m = json.loads(DEMO.read_text())
    m["sensors"][0]["required_data"] = 1e6  # no hover time can deliver this
    mp = tmp_path / "greedy.json"
    mp.write_text(json.dumps(m))
    out = tmp_path / "x.plan"
    r = run_cli("plan", mp, "-o", out, "--budget", 600, "--quiet")
    assert r.returncode == 1
    assert not out.exists() and list(tmp_path.iterdir()) == [mp]
    # `check` says CANNOT: refused before planning, with check's reason
    assert "nothing written" in r.stderr and "\n  CANNOT  sensor 'S1'" in r.stderr
    r = run_cli("plan", mp, "-o", out, "--budget", 600, "--quiet", "--allow-infeasible")
    assert r.returncode == 1 and out.exists()
    assert "INFEASIBLE" in r.stderr
    assert run_cli("verify", mp, out).returncode == 1


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["-o", "x.txt"], "-o/--output"),
        (["-o", "x.plan", "--plot", "x.jpg"], "--plot"),
        (["-o", "x.plan", "--budget", "3"], "--budget"),
        (["-o", "x.plan", "--starts", "-1"], "--starts"),
    ],
)
@pytest.mark.slow  # measured 5 s over 4 cases (issue 35: default suite <= 5 min)
def test_bad_input_exits_2_with_one_line(tmp_path: Path, args: list[str], needle: str) -> None:
    r = run_cli("plan", DEMO, *args, cwd=tmp_path)
    assert r.returncode == 2
    assert needle in r.stderr and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_a_folder_output_for_a_single_flight_map_says_why(tmp_path: Path) -> None:
    """A reviewer's `plan small-demo.json -o outdir/` was told "cannot tell the format from
    the suffix": a folder is the output of a map with a battery or fleet, and the line says
    so, naming the files a single flight is written to."""
    for out in ("outdir/", str(tmp_path)):
        r = run_cli("plan", DEMO, "-o", out, "--budget", 300, cwd=tmp_path)
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
        assert "a folder; a map without a battery or fleet is planned as a single flight " \
               "into one file (.plan, .waypoints or .geojson)" in r.stderr
    assert list(tmp_path.iterdir()) == []


def test_bad_map_exits_2(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text('{"area": {"width": 10, "height": 10}, "start": [0, 0], "end": [1, 1]}')
    r = run_cli("plan", bad, "-o", tmp_path / "x.plan")
    assert r.returncode == 2 and "sensors: required field is missing" in r.stderr
    assert not (tmp_path / "x.plan").exists()


@pytest.mark.slow  # measured 6 s (issue 35: default suite <= 5 min)
def test_help_is_fast_and_lists_commands() -> None:
    code = ("import sys, time; t = time.perf_counter(); from lamde_mission.cli import "
            "build_parser; build_parser().format_help(); "
            "heavy = [m for m in ('numba', 'cvxpy', 'matplotlib', 'mavsdk', 'torch', 'scipy') "
            "if m in sys.modules]; print(heavy)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.stdout.strip() == "[]", r.stdout + r.stderr
    r = run_cli("--help")
    for cmd in ("plan", "verify", "show", "check", "schema", "generate"):
        assert cmd in r.stdout
    for cmd in ("plan", "verify", "show", "check", "schema", "generate"):
        assert run_cli(cmd, "--help").returncode == 0


@pytest.mark.slow  # measured 12 s (issue 35: default suite <= 5 min)
def test_example_script_plans_and_verifies(tmp_path: Path) -> None:
    script = MAPS.parent / "plan_and_verify.py"
    out = tmp_path / "ex.plan"
    r = subprocess.run([sys.executable, str(script), str(DEMO), str(out)], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    assert out.exists() and "C5" in r.stdout
    # as `plan`: no file for an infeasible plan, one line for a bad map
    bad = tmp_path / "inf.plan"
    r = subprocess.run([sys.executable, str(script), str(MAPS / "infeasible-demo.json"),
                        str(bad)], capture_output=True, text=True, timeout=300)  # fmt: skip
    assert r.returncode == 1 and "not written" in r.stdout and not bad.exists(), r.stdout
    r = subprocess.run([sys.executable, str(script), str(tmp_path / "none.json"), str(bad)],
                       capture_output=True, text=True, timeout=300)  # fmt: skip
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    # a battery map plans as sorties (one flight said feasible, then ENERGY failed on the file
    # it wrote); an output it cannot write (a traceback)
    for args in ((str(MAPS / "fleet-demo.json"), str(bad)), (str(DEMO), str(tmp_path / "t.txt"))):
        r = subprocess.run([sys.executable, str(script), *args], capture_output=True, text=True,
                           timeout=300)  # fmt: skip
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
        assert not Path(args[1]).exists()


@pytest.mark.slow  # measured 6 s (issue 35: default suite <= 5 min)
def test_plan_time_limit_and_bad_budgets_exit_2_with_one_line(tmp_path: Path) -> None:
    """A budget below the population and a non-positive time limit are refused up front (one
    line naming the option, exit 2, nothing written)."""
    out = tmp_path / "m.plan"
    for args, needle in ((["--budget", "50"], "--budget: must be an integer in [population (100)"),
                         (["--time-limit", "0"], "--time-limit: must be null or a number > 0"),
                         (["--time-limit", "-3"], "--time-limit: must be"),
                         (["--time-limit", "nan"], "--time-limit: must be")):
        r = run_cli("plan", DEMO, "-o", out, *args)
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2 and len(lines) == 1 and needle in lines[0], (args, r.stderr)
        assert not out.exists()


@pytest.mark.slow  # measured 9 s (issue 35: default suite <= 5 min)
def test_plan_time_limit_stops_the_improving_stages(tmp_path: Path) -> None:
    """With a budget no machine spends in 1.5 s the clock ends the run: the plan is written,
    its summary says so and the last stage is marked."""
    out, rep = tmp_path / "m.plan", tmp_path / "r.json"
    r = run_cli("plan", DEMO, "-o", out, "--budget", 10_000_000, "--time-limit", 1.5,
                "--report", rep)
    assert r.returncode == 0, r.stderr
    assert "stopped by the time limit" in r.stdout
    plan = json.loads(rep.read_text())["plan"]
    assert plan["stopped"] == "time limit" and plan["evaluations"] < 10_000_000
    assert plan["timings"]["planning"] < 1.5 + 1.0  # a stage stops at its next evaluation


@pytest.mark.slow  # measured 7 s (issue 35: default suite <= 5 min)
def test_plan_names_the_obstacles_rtl_crosses_by_the_maps_own_kinds(tmp_path: Path) -> None:
    """small-demo has a circle and a rectangle on the straight leg back: the refusal names
    them as the map does ('circle 0', 'rectangle 0'), not as the planning map orders them."""
    r = run_cli("plan", DEMO, "-o", tmp_path / "m.plan", "--finish", "rtl", "--budget", 500)
    assert r.returncode == 2
    assert "crosses circle 0, rectangle 0 (with the 10 m clearance)" in r.stderr, r.stderr
    assert "polygon 0" not in r.stderr


@pytest.mark.slow  # measured 14 s (issue 35: default suite <= 5 min)
def test_the_report_names_the_mission_it_belongs_to(tmp_path: Path) -> None:
    """The mission is renamed last, after the plot and the report, and the report carries the
    mission file's SHA-256: a run killed between the renames is told apart; nothing pending
    is left beside the outputs."""
    import hashlib

    out, rep = tmp_path / "m.waypoints", tmp_path / "r.json"
    r = run_cli("plan", DEMO, "-o", out, "--report", rep, "--budget", 1500, "--quiet")
    assert r.returncode == 0, r.stderr
    report = json.loads(rep.read_text())
    assert report["mission_sha256"] == hashlib.sha256(out.read_bytes()).hexdigest()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.waypoints", "r.json"]


@pytest.mark.slow  # measured 1.3 s on a loaded machine (default suite <= 5 min)
def test_plan_negative_seed_is_one_line_and_exit_2(tmp_path: Path) -> None:
    out = tmp_path / "m.plan"
    r = run_cli("plan", DEMO, "-o", out, "--seed", -1, "--budget", 500)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.strip().splitlines() == ["lamde-mission plan: --seed: must be an integer "
                                             ">= 0, got -1"]
    assert not out.exists()


def test_the_summary_names_a_scheduler_and_a_split_other_than_the_default() -> None:
    """`plan`'s summary line: nothing for the default scheduler at the default split, the DE's
    share whenever it differs (the default's own 0 beyond 160 sensors included), the
    scheduler and its choice when not the default."""
    from lamde_mission.commands.plan import _run_settings
    from planner_core.defaults import DE_SHARE
    from planner_core.pipeline.schedule import LARGE_DE_SHARE

    assert _run_settings({"de_share": DE_SHARE}) == ""
    assert _run_settings({"de_share": LARGE_DE_SHARE}) == ", DE share 0"
    assert _run_settings({"de_share": 0.4, "scheduler": "lamde-s",
                          "scheduler_choice": "default"}) == (
        ", scheduler lamde-s -> default, DE share 0.4")
    assert _run_settings({"de_share": DE_SHARE, "scheduler": "kicks-rebuild"}) == (
        ", scheduler kicks-rebuild")


def test_a_format_that_disagrees_with_the_suffix_is_refused_before_planning(tmp_path: Path,
                                                                           capsys) -> None:
    """`plan MAP -o x.plan --format waypoints` wrote QGC WPL text into x.plan (QGroundControl
    would not open it): one line naming --format and the suffix, exit 2, nothing written, no
    folder made by --mkdir; a sortie map takes only --format plan (its own line)."""
    from lamde_mission.cli import main

    new = tmp_path / "new"
    for out, fmt in ((new / "x.plan", "waypoints"), (new / "x.waypoints", "geojson"),
                     (new / "x.GeoJSON", "plan")):  # fmt: skip
        assert main(["plan", str(DEMO), "-o", str(out), "--format", fmt, "--mkdir"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith(
            f"lamde-mission plan: --format: format {fmt} disagrees with the suffix "
            f"{out.suffix.lower()} of {out} "), err
        assert not new.exists()
    assert main(["plan", str(MAPS / "fleet-demo.json"), "-o", str(new), "--format",
                 "waypoints"]) == 2  # fmt: skip
    assert "--format: not available for a map with a battery" in capsys.readouterr().err


def test_an_output_that_is_an_input_is_refused_before_planning(tmp_path: Path, capsys) -> None:
    """`plan farm.json -o r.plan --report farm.json` replaced the hand-written map with the
    report, and `-o farm.json` (a saved plan) would replace it too. One line, exit 2, the input
    kept."""
    from lamde_mission.cli import main

    farm = tmp_path / "farm.json"
    farm.write_text(DEMO.read_text())
    for args, needle in (
        (["plan", str(farm), "-o", str(tmp_path / "r.plan"), "--report", str(farm)],
         "--report"),
        (["plan", str(farm), "-o", str(farm)], "-o/--output"),  # a saved plan is .json too
    ):
        assert main(args) == 2, args
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith(f"lamde-mission plan: {needle}: "), err
        assert "is the map this command reads" in err[0], err
        assert farm.read_text() == DEMO.read_text()
    link = tmp_path / "link.json"  # a hard link: the same file, another resolved path
    link.hardlink_to(farm)
    assert main(["plan", str(farm), "-o", str(tmp_path / "r.plan"), "--report", str(link)]) == 2
    assert "is the map this command reads" in capsys.readouterr().err
    assert farm.read_text() == DEMO.read_text()
    assert not (tmp_path / "r.plan").exists()


@pytest.mark.slow  # measured 5.9 s on a loaded machine (default suite <= 5 min)
def test_overwriting_a_mission_keeps_its_mode_and_clears_a_killed_runs_pending_file(
        tmp_path: Path) -> None:
    """docs/planning.md: overwriting keeps the file's permissions (a 0600 mission stays 0600;
    it became 0644), and a pending mission a killed run left beside the target (process gone)
    is removed by the next write (the old `.m.lamde-pending-PID.plan` names never were)."""
    from planner_core.atomic import pending_path

    out = tmp_path / "m.plan"
    out.write_text("old")
    out.chmod(0o600)
    stale = pending_path(out).with_name(pending_path(out).name.replace(
        f"-{os.getpid()}-", "-999999999-"))
    stale.write_text("half a mission")
    r = run_cli("plan", DEMO, "-o", out, "--budget", 500, "--quiet")
    assert r.returncode == 0, r.stderr
    assert stat.S_IMODE(out.stat().st_mode) == 0o600
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.plan"]


@pytest.mark.parametrize(
    ("argv", "line"),
    [
        (["plan", "m.json", "-o", "x.plan", "--seed", "abc"],
         "lamde-mission plan: argument --seed: invalid int value: 'abc'"),
        (["mock-vehicle", "--loss", "x"],
         "lamde-mission mock-vehicle: argument --loss: invalid float value: 'x'"),
        (["map", "from-geojson", "a.geojson"],  # a nested sub-parser
         "lamde-mission map from-geojson: the following arguments are required: -o/--output"),
        # an unknown argument names the command it was given to, as every other error does
        # (it was "lamde-mission: unrecognized arguments: ..."); escaped, as every error line
        (["plan", "m.json", "-o", "x.plan", "--e\x1b[2Jx"],
         "lamde-mission plan: unrecognized arguments: --e\\x1b[2Jx"),
        (["plan", "m.json", "-o", "x.plan", "extra", "--bogus"],
         "lamde-mission plan: unrecognized arguments: extra --bogus"),
        (["map", "from-geojson", "a.geojson", "-o", "m.json", "--bogus"],
         "lamde-mission map from-geojson: unrecognized arguments: --bogus"),
    ],
)
def test_a_bad_argument_is_one_line_naming_it_and_exit_2(
    argv: list[str], line: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from lamde_mission.cli import main

    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    assert capsys.readouterr().err.splitlines() == [line]


def test_help_still_prints_the_usage(capsys: pytest.CaptureFixture[str]) -> None:
    from lamde_mission.cli import main

    with pytest.raises(SystemExit) as info:
        main(["plan", "--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: lamde-mission plan ") and "--seed" in out


def test_a_map_error_past_the_commands_checks_escapes_the_maps_path(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import lamde_mission.commands.check as check
    from lamde_mission.cli import main
    from planner_core.model.mapio import MapError

    def run(args: object) -> int:
        raise MapError(["sensors: required field is missing"])

    monkeypatch.setattr(check, "run", run)
    assert main(["check", "evil\x1b[2J\nname.json"]) == 2
    assert capsys.readouterr().err.splitlines() == [
        "lamde-mission check: evil\\x1b[2J\\nname.json: sensors: required field is missing"]


def test_the_status_line_rewrites_in_place_on_a_tty_and_steps_off_one() -> None:
    """`_StatusLine`, the writer behind the plan's progress bar and its setup lines: on a TTY
    one line rewritten in place ("\\r", padded to the widest so far), at most every `every` s
    unless forced, ended by `end` (idempotent; a final line padded over the open one); off a
    TTY a line of its own once past each step short of 1.0, or when forced. `now` is the
    caller's clock, so no wall time is involved."""
    import io

    from lamde_mission.commands.plan import _StatusLine

    class Stream(io.StringIO):
        def __init__(self, tty: bool) -> None:
            super().__init__()
            self.tty = tty

        def isatty(self) -> bool:
            return self.tty

    out = Stream(tty=True)
    line = _StatusLine(out, every=0.1)
    assert line.tty()
    assert line.show("abcdef", 0.1, now=10.0)
    assert not line.show("skipped", 0.2, now=10.05)  # within `every` of the last
    assert line.show("xy", 0.3, now=10.2)  # padded over "abcdef"
    assert line.show("forced", 0.3, now=10.21, force=True)
    line.end("done")
    line.end()  # ended already: nothing more
    assert out.getvalue() == "\rabcdef\rxy    \rforced\rdone  \n"
    assert line.show("ab", 0.1, now=10.22)  # afresh: due at once, no padding of old lines
    line.end()
    assert out.getvalue().endswith("\rdone  \n\rab\n")

    out = Stream(tty=False)
    line = _StatusLine(out, every=0.1, step=0.25)
    assert not line.tty()
    for frac in (0.1, 0.3, 0.4, 0.8, 0.9, 1.0):  # time plays no part off a TTY
        line.show(f"at {frac}", frac, now=0.0)
    line.show("forced", 1.0, now=0.0, force=True)
    line.end()  # no line is open off a TTY
    line.end("done")
    assert out.getvalue() == "at 0.3\nat 0.8\nforced\ndone\n"
    line.show("again", 0.3, now=0.0)  # `end` starts the steps afresh
    assert out.getvalue().endswith("done\nagain\n")

    told = _StatusLine(Stream(tty=False), tty=lambda: True)  # the caller's say wins
    told.show("x", 0.0, now=0.0)
    assert told.tty() and told.out.getvalue() == "\rx"


@pytest.mark.parametrize("cannot", ["too much data", "walled in"])
def test_a_map_check_says_cannot_is_refused_before_planning(tmp_path: Path, monkeypatch,
                                                            cannot: str) -> None:
    """A map `lamde-mission check` says CANNOT for: `plan` ran its whole budget and only then
    printed check's reasons (over two minutes on a 2,000-footprint campus that C3 rules out,
    where check says CANNOT in 10 s). It now runs check's diagnosis first and refuses the map
    with check's reasons, exit status 1 as for any plan it cannot make, nothing written, the
    planner never started; --allow-infeasible still plans it (to write the best mission it
    finds)."""
    import lamde_mission.api as api
    from lamde_mission.fuzz import run_cli as run_here

    m = json.loads((MAPS / "tiny.json").read_text())
    if cannot == "too much data":
        m["sensors"][0]["required_data"] = 1e6  # no I_max hover points of T_max can collect it
    else:
        m["end"] = [500, 500]  # inside four walls
        m["obstacles"]["circles"] = []
        m["obstacles"]["rectangles"] = [
            {"x": 500, "y": 400, "length": 260, "width": 20},
            {"x": 500, "y": 600, "length": 260, "width": 20},
            {"x": 400, "y": 500, "length": 20, "width": 260},
            {"x": 600, "y": 500, "length": 20, "width": 260}]  # fmt: skip
    path = tmp_path / "cannot.json"
    path.write_text(json.dumps(m))
    said = run_here(["check", str(path)])
    assert said.status == 1, (said.stdout, said.error)
    reasons = [ln.split("CANNOT", 1)[1].strip() for ln in said.stdout.splitlines()
               if ln.strip().startswith("CANNOT")]  # fmt: skip
    assert reasons

    def planner(*args, **kwargs):
        raise AssertionError("the planner ran")

    monkeypatch.setattr(api, "plan", planner)
    out = tmp_path / "x.plan"
    for quiet in ([], ["--quiet"]):
        r = run_here(["plan", str(path), "-o", str(out), "--budget", "600", *quiet])
        assert r.status == 1 and r.error is None, (r.stderr, r.error)
        lines = r.stderr.splitlines()
        assert lines[0] == (f"lamde-mission plan: no feasible mission for {path}: `lamde-mission "
                            "check` says CANNOT (no plan can meet this map), so it was not "
                            "planned; nothing written:")
        assert lines[1:-1] == [f"  CANNOT  {why}" for why in reasons]  # as check says them
        assert lines[-1].startswith("  --allow-infeasible plans it anyway")
        assert r.stdout == "" and list(tmp_path.iterdir()) == [path]
    r = run_here(["plan", str(path), "-o", str(out), "--budget", "600", "--allow-infeasible"])
    assert isinstance(r.error, AssertionError) and "CANNOT" not in r.stderr  # planned, as before


def test_plan_reads_its_map_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`plan` loaded the map to see whether it gives a battery or a fleet, then loaded it again
    to plan it: 2.5 s a run on a 2,000-footprint campus. The first load is handed on."""
    from lamde_mission.cli import main
    from planner_core.model import mapio

    loads: list[str] = []
    real = mapio.load_map

    def counted(path, *a, **k):  # noqa: ANN001, ANN002, ANN003, ANN202
        if isinstance(path, str | os.PathLike):  # a file read (a Map passes through)
            loads.append(str(path))
        return real(path, *a, **k)

    monkeypatch.setattr(mapio, "load_map", counted)
    out = tmp_path / "t.plan"
    assert main(["plan", str(MAPS / "tiny.json"), "-o", str(out), "--budget", "600",
                 "--quiet"]) == 0
    assert out.exists() and loads == [str(MAPS / "tiny.json")]


def test_after_a_failed_plan_each_cannot_lead_is_said_once(capsys) -> None:
    """`_say_cannot` (after a plan of sorties failed): one finding keeps its one line; several
    under one lead are listed beneath it as check's CANNOT lines, not each behind the lead."""
    from lamde_mission.commands.plan import _say_cannot
    from planner_core.model.diagnose import diagnose
    from planner_core.model.mapio import load_map

    d = json.loads((MAPS / "small-demo.json").read_text())
    d.pop("witness")
    d["sensors"][0]["required_data"] = d["sensors"][1]["required_data"] = 1e6
    m = load_map(d)
    why = [f.message for f in diagnose(m).findings if f.fatal]
    assert len(why) == 2
    _say_cannot(m)
    assert capsys.readouterr().err.splitlines() == [
        "  no plan can meet this map (`lamde-mission check` says CANNOT):",
        f"    CANNOT  {why[0]}", f"    CANNOT  {why[1]}"]
    _say_cannot(m, said=why[0])  # what the failure's own message said is not said again
    assert capsys.readouterr().err.splitlines() == [
        f"  no plan can meet this map (`lamde-mission check` says CANNOT): {why[1]}"]


@pytest.mark.parametrize("extra", [["--sortie-budget", "150"], ["--rounds", "2"],
                                   ["--objective", "makespan"]])
def test_a_map_that_does_not_load_is_named_before_the_sortie_options(tmp_path, extra) -> None:
    """`plan MISSING -o d/ --sortie-budget 150` said "--sortie-budget: the map has no battery
    and no fleet" (the map never loaded, so it had none), and without the option "-o: cannot
    tell the format" for the sortie directory it meant: the map's own line comes first."""
    from lamde_mission.fuzz import run_cli as run_here

    missing = tmp_path / "nowhere.json"
    r = run_here(["plan", str(missing), "-o", str(tmp_path / "d") + "/", *extra])
    assert r.status == 2 and r.stderr.strip() == f"lamde-mission plan: {missing}: file not found"
    assert list(tmp_path.iterdir()) == []


def test_past_40_sensors_the_summary_lists_the_least_served_and_the_report_all(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A newcomer: `plan` on a 200-sensor map printed 200 per-sensor lines. Past
    SENSOR_LINES (40: the paper's maps print as before) it lists the SENSORS_SHOWN least
    served, and counts the rest with the least margin among them; --verbose lists every
    sensor, and --report holds every sensor as the simulator replayed it."""
    from lamde_mission.cli import main
    from lamde_mission.commands.plan import SENSOR_LINES, SENSORS_SHOWN

    farm, out, rep = tmp_path / "farm.json", tmp_path / "m.plan", tmp_path / "r.json"
    assert main(["generate", str(farm), "--layout", "clustered", "--size", "10000",
                 "--sensors", "48", "--cluster-size", "12", "--seed", "7"]) == 0  # fmt: skip
    capsys.readouterr()
    plan = ["plan", str(farm), "-o", str(out), "--budget", "300", "--report", str(rep)]
    assert main(plan) == 0
    text = capsys.readouterr().out
    lines = text.splitlines()
    head = lines.index(f"  data collected vs required (Mbit), the {SENSORS_SHOWN} least "
                       "served of 48 sensors:")
    rows = lines[head + 1: head + 1 + SENSORS_SHOWN]
    assert all(r.startswith("    S") and " ok " in r for r in rows)
    more = lines[head + 1 + SENSORS_SHOWN]
    assert more.startswith(f"    ... and {48 - SENSORS_SHOWN} more, all ok (the least +")
    assert more.endswith("above its requirement); every sensor: --verbose, or --report's "
                         '"sensors"')
    sensors = json.loads(rep.read_text())["sensors"]
    assert [s["id"] for s in sensors] == [f"S{k:02d}" for k in range(1, 49)]
    margins = sorted(s["collected"] / s["required"] for s in sensors)
    shown = [float(r.split()[1]) / float(r.split()[3]) for r in rows]
    assert shown == pytest.approx(margins[:SENSORS_SHOWN], abs=1e-3)  # the least served
    assert 48 > SENSOR_LINES
    assert main([*plan, "--verbose"]) == 0
    lines = capsys.readouterr().out.splitlines()
    head = lines.index("  data collected vs required (Mbit):")
    assert [r.split()[0] for r in lines[head + 1: head + 49]] == [s["id"] for s in sensors]


def test_the_short_sensors_are_always_listed() -> None:
    from lamde_mission.commands.plan import SENSORS_SHOWN, _sensor_lines

    rows = [{"id": f"s{k}", "collected": 10.0 + k, "required": 10.0, "ok": True}
            for k in range(60)]  # fmt: skip
    for k in (30, 50, 59):  # short, and beyond the 10 least served by position
        rows[k] = {"id": f"s{k}", "collected": 5.0, "required": 10.0, "ok": False}
    lines = _sensor_lines(rows)
    names = [ln.split()[0] for ln in lines[1:-1]]
    assert names[:3] == ["s30", "s50", "s59"] and len(names) == SENSORS_SHOWN
    assert all("SHORT" in ln for ln in lines[1:4])
    assert lines[-1].startswith("    ... and 50 more, all ok (the least +70.00 % above")
    rows = [dict(r, collected=1.0, ok=False) for r in rows]  # every one short: all listed
    lines = _sensor_lines(rows)
    assert len(lines) == 61 and "more" not in lines[-1]
    assert len(_sensor_lines(rows[:40])) == 41  # 40 sensors: every one, as before

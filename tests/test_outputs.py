"""Outputs fail before the work: `plan`'s output paths are checked before the optimisation;
the atomic writer cleans temp files of killed writes and keeps an existing file's mode; names
and ids from a map are printed with control characters escaped (issue 20)."""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from planner_core.atomic import (
    OutputPathError,
    check_writable,
    clean_stale_dirs,
    clean_stale_temps,
    dir_beside,
    write_text_atomic,
)
from planner_core.textio import counted, for_count, printable, rounded_up
from tests.conftest import MAPS, run_cli, run_cli_many

DEMO = MAPS / "small-demo.json"


def _bad_outputs(tmp: Path) -> dict[str, list[str]]:
    afile = tmp / "afile"
    afile.write_text("x")
    folder = tmp / "folder.plan"
    folder.mkdir()
    ro = tmp / "ro.plan"
    ro.write_text("old")
    ro.chmod(0o444)
    return {
        "is a folder": ["-o", str(folder)],
        "is a file, not a folder": ["-o", str(afile / "m.plan")],
        "does not exist": ["-o", str(tmp / "missing" / "m.plan")],
        # /sys refuses new files even to root: a read-only folder whoever runs the test
        "cannot write in the folder": ["-o", "/sys/lamde-test.plan"],
        "read-only": ["-o", str(ro)],
        "--report": ["-o", str(tmp / "ok.plan"), "--report", str(folder)],
        "--plot": ["-o", str(tmp / "ok.plan"), "--plot", str(afile / "p.png")],
        "also the": ["-o", str(tmp / "same.plan"), "--report", str(tmp / "same.plan")],
    }


@pytest.mark.slow  # measured 5 s (issue 35: default suite <= 5 min)
def test_every_bad_output_exits_2_before_the_optimisation(tmp_path: Path) -> None:
    cases = _bad_outputs(tmp_path)
    # the default budget: an optimisation that started would show progress lines on stderr
    results = run_cli_many(*[("plan", DEMO, *args) for args in cases.values()], timeout=120)
    for (needle, args), r in zip(cases.items(), results, strict=True):
        assert r.returncode == 2, (args, r.stderr)
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and needle in lines[0], (args, r.stderr)
        assert "evals" not in r.stderr and "Traceback" not in r.stderr
        assert r.stdout == ""
    assert not (tmp_path / "missing").exists()  # no silent folder creation
    assert not (tmp_path / "ok.plan").exists()
    assert (tmp_path / "ro.plan").read_text() == "old"


def test_bad_outputs_are_refused_before_the_map_is_read_or_the_planner_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """In this process, with the map reader and the planner replaced by tripwires: every bad
    output exits 2 before either is reached (so the refusal costs no optimisation, whatever the
    budget)."""
    import lamde_mission.api
    import lamde_mission.commands._common
    from lamde_mission.cli import main

    def tripwire(*_a: object, **_k: object) -> None:
        raise AssertionError("reached past the output check")

    monkeypatch.setattr(lamde_mission.api, "plan", tripwire)
    monkeypatch.setattr(lamde_mission.commands._common, "load_map_or_fail", tripwire)
    for needle, args in _bad_outputs(tmp_path).items():
        capsys.readouterr()
        assert main(["plan", str(DEMO), "--budget", "1000000", *args]) == 2, args
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and needle in err[0], (args, err)


@pytest.mark.slow  # measured 8 s (issue 35: default suite <= 5 min)
def test_mkdir_creates_the_folder(tmp_path: Path) -> None:
    out = tmp_path / "new" / "deeper" / "m.waypoints"
    r = run_cli("plan", DEMO, "-o", out, "--budget", 600, "--quiet", "--mkdir",
                "--allow-infeasible")  # fmt: skip
    assert r.returncode in (0, 1), r.stderr
    assert out.read_text().startswith("QGC WPL 110")


def test_check_writable_cases(tmp_path: Path) -> None:
    ok = tmp_path / "ok.plan"
    assert check_writable(ok) == ok and not ok.exists()
    with pytest.raises(OutputPathError, match="--report: .*is a folder"):
        check_writable(tmp_path, what="--report")
    with pytest.raises(OutputPathError, match="does not exist"):
        check_writable(tmp_path / "a" / "b.plan")
    check_writable(tmp_path / "a" / "b.plan", mkdir=True)
    assert (tmp_path / "a").is_dir()
    assert list((tmp_path / "a").iterdir()) == []  # the probe left nothing


def test_stale_temp_of_a_killed_write_is_cleaned(tmp_path: Path) -> None:
    out = tmp_path / "m.plan"
    # a write killed between its temp file and the rename (SIGKILL in the write window)
    code = ("import os, tempfile; from planner_core.atomic import _tmp_prefix; "
            "from pathlib import Path; "
            f"fd, t = tempfile.mkstemp(prefix=_tmp_prefix(Path({str(out)!r})), "
            f"dir={str(tmp_path)!r}); os.write(fd, b'half'); os.kill(os.getpid(), 9)")  # fmt: skip
    subprocess.run([sys.executable, "-c", code], check=False)
    left = [p.name for p in tmp_path.iterdir()]
    assert len(left) == 1 and left[0].startswith(".m.plan.lamde-tmp-"), left
    # a live writer's temp file (this process) is not touched
    mine = tmp_path / f".m.plan.lamde-tmp-{os.getpid()}-live"
    mine.write_text("in progress")
    write_text_atomic(out, "new")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["m.plan", mine.name])
    assert out.read_text() == "new"
    mine.unlink()
    assert clean_stale_temps(out) == []


def test_stale_folders_of_a_killed_folder_write_are_cleaned(tmp_path: Path) -> None:
    """`dir_beside`/`clean_stale_dirs`: a folder written whole (a sortie directory) is filled
    as `.NAME.lamde-pending-PID`; only real folders of that name of a process gone are removed
    (not this process's, nor a file or a link of that name, nor another kind's when not asked)."""
    out = tmp_path / "d"
    assert dir_beside(out, "pending") == tmp_path / f".d.lamde-pending-{os.getpid()}"
    with pytest.raises(ValueError, match="kind: must be one of pending, old, got 'tmp'"):
        dir_beside(out, "tmp")
    pid, pid2, pid3 = (int(subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
        text=True, check=True).stdout) for _ in range(3))  # exited and reaped
    stale, old = tmp_path / f".d.lamde-pending-{pid}", tmp_path / f".d.lamde-old-{pid}"
    for f in (stale, old, dir_beside(out, "pending")):
        (f / "sub").mkdir(parents=True)
    afile = tmp_path / f".d.lamde-pending-{pid2}"
    afile.write_text("x")
    link = tmp_path / f".d.lamde-pending-{pid3}"
    link.symlink_to(old, target_is_directory=True)
    assert clean_stale_dirs(out, ("pending",)) == [stale]
    assert old.is_dir() and afile.is_file() and link.is_symlink()
    assert dir_beside(out, "pending").is_dir()  # this process's own: its writer's to remove
    assert clean_stale_dirs(out) == [old]


def test_overwrite_keeps_the_mode(tmp_path: Path) -> None:
    out = tmp_path / "secret.plan"
    out.write_text("old")
    out.chmod(0o600)
    write_text_atomic(out, "new")
    assert stat.S_IMODE(out.stat().st_mode) == 0o600 and out.read_text() == "new"
    fresh = tmp_path / "fresh.plan"
    write_text_atomic(fresh, "x")
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(fresh.stat().st_mode) == 0o666 & ~umask


def test_write_without_mkdir_refuses_a_missing_folder(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        write_text_atomic(tmp_path / "no" / "x.txt", "x", mkdir=False)
    assert not (tmp_path / "no").exists()


def test_printable_escapes_controls() -> None:
    assert printable("S1") == "S1" and printable("Zürich 東京") == "Zürich 東京"
    assert printable("a\nb") == "a\\nb"
    assert printable("\x1b[2J") == "\\x1b[2J"
    assert printable("x\u202ey\u2028") == "x\\u202ey\\u2028"
    assert printable("\x9b") == "\\x9b"


def test_counted_is_singular_for_one_only() -> None:
    # "1 obstacles", "1 sorties", "1 battery swaps" were printed
    assert counted(1, "battery swap") == "1 battery swap"
    assert counted(0, "no-fly zone") == "0 no-fly zones"
    assert counted(2, "sortie") == "2 sorties" and counted(1, "sortie") == "1 sortie"
    assert counted(1001, "sortie") == "1,001 sorties"
    assert counted(3, "child", "children") == "3 children" and counted(1, "child") == "1 child"
    # the word alone, after a list or as a verb agreeing with a count
    assert for_count(1, "optimiser") == "optimiser" and for_count(2, "optimiser") == "optimisers"
    assert for_count(1, "replaces", "replace") == "replaces"
    assert for_count(0, "replaces", "replace") == "replace"


def test_rounded_up_never_prints_less_than_the_value() -> None:
    # plan's suggested battery printed 15.26 Wh for a 15.2615 Wh need (round to nearest)
    assert rounded_up(15.2615, 2) == 15.27 and f"{rounded_up(15.2615, 2):.2f}" == "15.27"
    assert rounded_up(326.08) == 327.0 and rounded_up(306.0) == 306.0
    assert rounded_up(14.31, 2) == 14.31  # already on the grid: unchanged
    for x in (0.1 + 0.2, 1.005, 2.675, 1e-9, 123456.789):
        for places in (0, 1, 2, 3):
            assert float(f"{rounded_up(x, places):.{places}f}") >= x


@pytest.mark.parametrize("field", ["name", "id"])
@pytest.mark.slow  # measured 11 s over 2 cases (issue 35: default suite <= 5 min)
def test_plan_never_prints_a_maps_control_characters(field: str, tmp_path: Path) -> None:
    """The map reader refuses C0 controls in names and ids; whatever it lets through (format
    characters such as a bidi override) is printed escaped, and a refusal prints no raw bytes."""
    for k, evil in enumerate(["demo\nwrote /etc/passwd\x1b[2J", "demo\u202egnp.exe\u200b"]):
        m = json.loads(DEMO.read_text())
        if field == "name":
            m["name"] = evil
        else:
            m["sensors"][0]["id"] = evil
        mp = tmp_path / f"evil{k}.json"
        mp.write_text(json.dumps(m))
        r = run_cli("plan", mp, "-o", tmp_path / f"m{k}.plan", "--budget", 600,
                    "--allow-infeasible")  # fmt: skip
        out = r.stdout + r.stderr
        assert r.returncode in (0, 1, 2), r.stderr
        for raw in ("\x1b", "\u202e", "\u200b"):
            assert raw not in out
        assert not any(line.startswith("wrote /etc") for line in out.splitlines())
        if r.returncode != 2:
            assert printable(evil) in r.stdout

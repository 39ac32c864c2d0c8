"""Messages that say what happened (issue 32, items 6 and 7): `train` without torch, `upload
--map` saying the simulator's check passed, and Ctrl-C while a command is still starting.

(The ENDS margin as a slack: tests/test_sim.py; a building's NAME kept by `map from-geojson`:
tests/test_strict_inputs.py.)
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from lamde_mission.cli import INTERRUPTED
from lamde_mission.fuzz import run_cli


def _default_sigint() -> None:
    """In the child before exec: SIGINT at its default, as a terminal gives it; a runner
    started in the background (`&`, CI without job control) hands its children SIGINT
    ignored, and Python then installs no handler of its own."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


ROOT = Path(__file__).resolve().parent.parent
TINY = ROOT / "tests" / "data" / "hostile" / "tiny-map.json"


def test_train_without_torch_is_one_line(monkeypatch, tmp_path) -> None:
    monkeypatch.setitem(sys.modules, "torch", None)  # `import torch` now fails, as uninstalled
    out = run_cli(["train", "-o", str(tmp_path / "p.pt")])
    assert out.error is None, out.error
    assert out.status == 2 and out.stderr.splitlines() == [
        "lamde-mission train: train needs torch: pip install 'lamde-mission[train]'"]
    assert list(tmp_path.iterdir()) == []


def test_upload_with_map_says_the_simulators_check_passed(tmp_path, port) -> None:
    from tests.test_altitudes import good_items, write
    from tests.vehicle_helpers import listen_on, mock_on

    path = write(tmp_path, good_items(), ".plan")
    with mock_on(port):
        out = run_cli(["upload", str(path), "--map", str(TINY), "--via", "pymavlink",
                       "--connect", listen_on(port), "--timeout", "10"])  # fmt: skip
    assert out.status == 0, out.stderr
    first = out.stdout.splitlines()[0]
    assert first.startswith("simulator: all constraints hold on ") and str(TINY) in first


def test_a_ctrl_c_inside_main_is_one_line_in_process(monkeypatch) -> None:
    import lamde_mission.cli as cli

    def boom(argv):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "_main", boom)
    out = run_cli(["check", str(TINY)])
    assert out.status == 130 and out.stderr.splitlines() == [INTERRUPTED]


def test_a_ctrl_c_inside_a_compiled_kernel_is_one_line(monkeypatch) -> None:
    """A SIGINT while a numba kernel runs (the visibility graph's `_tangent_pairs` on a large
    campus) comes out of the dispatcher as `SystemError: CPUDispatcher(...) returned a result
    with an exception set`, caused by the KeyboardInterrupt: one line and 130, no traceback.
    Any other SystemError is not swallowed."""
    import lamde_mission.cli as cli

    def kernel(argv):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as e:
            raise SystemError("CPUDispatcher(<function _tangent_pairs>) returned a result "
                              "with an exception set") from e

    monkeypatch.setattr(cli, "_main", kernel)
    out = run_cli(["check", str(TINY)])
    assert out.status == 130 and out.stderr.splitlines() == [INTERRUPTED]

    def other(argv):
        raise SystemError("something else")

    monkeypatch.setattr(cli, "_main", other)
    with pytest.raises(SystemError, match="something else"):
        cli.main(["check", str(TINY)])


def test_a_ctrl_c_in_the_visibility_graph_ends_as_the_other_interrupts(monkeypatch,
                                                                        tmp_path) -> None:
    """A Ctrl-C during `plan`'s setup, the visibility graph's build half done with its
    percentage line open: the line is ended and "lamde-mission: interrupted" follows on its
    own (status 130), with no "setup: done in" for the stage cut short (the CLI printed one),
    and nothing written."""
    import planner_core.model.seeding as seeding
    from lamde_mission.commands import plan as plan_cmd
    from tests.test_api import shown_at_once

    build = seeding.build_visibility_graph

    def cut(obstacles, width, height, margin, *, progress=None):
        if progress is None:  # the kernels' warm-up
            return build(obstacles, width, height, margin)
        progress(0.5)
        raise KeyboardInterrupt

    monkeypatch.setattr(seeding, "build_visibility_graph", cut)
    notices = [type(shown_at_once(tty=tty)) for tty in (True, False)]  # before the patch
    for notice in notices:
        monkeypatch.setattr(plan_cmd, "SetupNotice", lambda n=notice: n(after=0.0))
        out = run_cli(["plan", str(ROOT / "examples" / "maps" / "tiny.json"), "-o",
                       str(tmp_path / "t.plan"), "--budget", "600"])  # fmt: skip
        assert out.status == 130, (out.stderr, out.error)
        lines = out.stderr.splitlines()
        assert lines[-1] == INTERRUPTED and "done in" not in lines[-2], lines
        assert lines[-2].split("\r")[-1].startswith("setup: the visibility graph  50 %")
        assert list(tmp_path.iterdir()) == []


def test_importing_the_package_leaves_sigint_alone() -> None:
    """Only the console script gets the start-up handler; a program importing the package
    keeps Python's own."""
    # compared with what the child started with: a runner started in the background (`&`)
    # hands its children SIGINT ignored, not Python's default handler
    code = ("import signal; before = signal.getsignal(signal.SIGINT); "
            "import lamde_mission, lamde_mission.cli; "
            "print(signal.getsignal(signal.SIGINT) is before)")  # fmt: skip
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=60, cwd=ROOT)  # fmt: skip
    assert r.stdout.strip() == "True", r.stderr


def test_the_cli_module_imports_nothing_heavy_at_the_top() -> None:
    """What runs before `main`'s handler is `lamde_mission` and `lamde_mission.cli` alone."""
    code = ("import sys; before = set(sys.modules); import lamde_mission.cli; "
            "print(sorted(set(sys.modules) - before))")  # fmt: skip
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=60, cwd=ROOT)  # fmt: skip
    # `__future__` (the stdlib's table of compiler flags, < 1 ms) comes with the modules'
    # `from __future__ import annotations`; whether `site` already loaded it depends on the
    # install (setuptools' editable finder does, a plain path entry does not)
    loaded = set(json.loads(r.stdout.replace("'", '"'))) - {"__future__"}
    assert sorted(loaded) == ["lamde_mission", "lamde_mission.cli"]


#: `check` as the console script runs it (`sys.argv[0]` is "lamde-mission"), started without
#: the `site` module (-S, its paths given by hand); it says "ready" on stdout once the package's
#: first lines have run (they set the script's SIGINT handler). Before them, a Ctrl-C is the
#: interpreter's own (its start-up takes 10-40 ms here, the installed script's `site` with
#: setuptools' editable finder 30-70 ms more) and no code of the project can answer it.
_CHECK = ("import sys; sys.path[:0] = {paths!r}; sys.argv[0] = 'lamde-mission'; "
          "import lamde_mission; sys.stdout.write('ready\\n'); sys.stdout.flush(); "
          "from lamde_mission.cli import main; sys.exit(main(['check', {tiny!r}]))")  # fmt: skip


@pytest.mark.parametrize("delay", [0.0, 0.01, 0.02, 0.03, 0.05, 0.07, 0.1])
def test_sigint_while_starting_gives_one_line_and_130(delay: float) -> None:
    """SIGINT 0-0.1 s after the package's first lines ran (`check` then imports the CLI, numpy,
    pydantic, shapely, numba-compiled code...): one line and status 130; never a traceback. A
    command that finished first is judged as usual."""
    import sysconfig

    paths = [str(ROOT), sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]]
    code = _CHECK.format(paths=paths, tiny=str(TINY))
    p = subprocess.Popen([sys.executable, "-S", "-c", code], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, cwd=ROOT,
                         preexec_fn=_default_sigint)  # fmt: skip
    assert p.stdout is not None and p.stdout.readline() == "ready\n"
    time.sleep(delay)
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=120)
    assert "Traceback" not in err and "Exception ignored" not in err, (delay, err)
    if p.returncode == 130:
        assert err.splitlines() == [INTERRUPTED]
    else:
        assert p.returncode == 0 and "map 'case-tiny'" in out, (p.returncode, err)


def test_verify_lists_every_margin_of_a_small_map_and_the_least_of_a_large_one() -> None:
    from lamde_mission.commands.verify import MARGINS_LISTED, _margins

    few = {"a": 0.05, "b": 0.031}
    assert _margins(few) == "'a' +5 %, 'b' +3.1 %"
    many = {f"s{i:02d}": 0.01 * i for i in range(80)}
    text = _margins(many)
    assert text.startswith("'s00' +0 %, 's01' +1 %") and "'s09' +9 %" in text
    assert "'s10'" not in text and text.count("'") == 20
    assert text.endswith("(the 10 least of 80 sensors; median +40 %, most +79 %)")
    assert "least" not in _margins({f"s{i}": 0.0 for i in range(MARGINS_LISTED)})

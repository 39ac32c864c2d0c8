"""Shared fixtures (small hand-readable maps built in code) and the one CLI runner."""

from __future__ import annotations

import ast
import copy
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
MAPS = ROOT / "examples" / "maps"
SUITE = MAPS / "suite"

HAND_MAP = {
    "name": "hand",
    "area": {"width": 1000, "height": 1000},
    "start": [0, 0],
    "end": [300, 400],
    "sensors": [
        {"id": "a", "x": 300, "y": 0},
        {"id": "b", "x": 300, "y": 300, "required_data": 400},
    ],
    "uav": {"max_hover_points": 2},
    "radio": {"bandwidth": 15},
}


@pytest.fixture
def hand_map() -> dict:
    """Hover at (300, 0) for 50 s between start (0, 0) and end (300, 400): every term by hand."""
    return copy.deepcopy(HAND_MAP)


def run_cli(
    *args: str | Path, cwd: str | Path | None = None, timeout: float = 300
) -> subprocess.CompletedProcess[str]:
    """Run ``lamde-mission ARGS`` in a fresh process (``python -m lamde_mission.cli``); text
    stdout/stderr captured. Paths may be given as Path objects."""
    return run_cli_many(args, cwd=cwd, timeout=timeout)[0]


def run_cli_many(
    *calls: tuple[str | Path, ...], cwd: str | Path | None = None, timeout: float = 300
) -> list[subprocess.CompletedProcess[str]]:
    """Run several ``lamde-mission`` commands at once, in parallel (each process spends seconds
    importing); results in the order given."""
    cmds = [[sys.executable, "-m", "lamde_mission.cli", *map(str, c)] for c in calls]
    pipe = subprocess.PIPE
    procs = [(c, subprocess.Popen(c, stdout=pipe, stderr=pipe, text=True, cwd=cwd or ROOT))
             for c in cmds]
    out = []
    for cmd, p in procs:
        try:
            stdout, stderr = p.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            p.kill()
            p.communicate()
            raise
        out.append(subprocess.CompletedProcess(cmd, p.returncode, stdout, stderr))
    return out


def modules_after(code: str, package: str, timeout: float = 300) -> list[str]:
    """The modules of `package` (it and its submodules) that a fresh interpreter has imported
    after running `code` from the repository root; fails the test with its stderr if `code`
    fails."""
    probe = (f"\nimport sys as _s\nprint(sorted(m for m in _s.modules "
             f"if m == {package!r} or m.startswith({package + '.'!r})))\n")
    out = subprocess.run([sys.executable, "-c", code + probe], capture_output=True, text=True,
                         cwd=ROOT, timeout=timeout)
    assert out.returncode == 0, out.stderr
    return ast.literal_eval(out.stdout.strip().splitlines()[-1])


def one_line_error(r: subprocess.CompletedProcess[str]) -> str:
    """Assert the CLI's bad-input contract (exit 2, no traceback, one stderr line); the line."""
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, r.stderr
    return lines[0]


@pytest.fixture
def port() -> int:
    """A free UDP port on 127.0.0.1 for a mock vehicle (tests.vehicle_helpers.mock_on)."""
    from tests.vehicle_helpers import free_udp_port

    return free_udp_port()


def drawn_figures(monkeypatch: pytest.MonkeyPatch) -> list:
    """The figures `lamde_mission.plot.mission_figure` draws from now on in this test, in
    order (it is wrapped, not replaced): for tests that run `show` or `plan --plot` in this
    process and then read the figure."""
    from lamde_mission import plot

    drawn: list = []
    real = plot.mission_figure

    def keep(*args, **kw):
        drawn.append(real(*args, **kw))
        return drawn[-1]

    monkeypatch.setattr(plot, "mission_figure", keep)
    return drawn


def plan_at(m, hover, times):
    """A Plan-like record of the given hover points and times on map `m` (breakdown by the
    model), for drawing and replay tests that need a known plan without running the DE."""
    from types import SimpleNamespace

    import numpy as np

    from planner_core.model.problem import Problem

    p = Problem(m)
    b = p.breakdown(p.encode(hover, times))
    return SimpleNamespace(hover_points=np.array(b["hover_points"]),
                           hover_times=np.array(b["hover_times"]), f=b["f"], phi=b["phi"],
                           feasible=b["phi"] == 0, breakdown=b)  # fmt: skip


#: the heartbeat watch (`claims.HEARTBEAT_WATCH_S`, 1.2 s in the product) of an in-process
#: upload in a test: the mocks send their first HEARTBEAT as they start, so a transfer test need
#: not wait for a second one; tests of the watch itself carry `@pytest.mark.full_watch`
TEST_HEARTBEAT_WATCH_S = 0.3


@pytest.fixture(autouse=True)
def _short_heartbeat_watch(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch):
    if request.node.get_closest_marker("full_watch") is None:
        from lamde_mission.vehicle import claims

        monkeypatch.setattr(claims, "HEARTBEAT_WATCH_S", TEST_HEARTBEAT_WATCH_S)
    yield

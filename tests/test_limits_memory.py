"""Memory at the documented input limits (issue 32, item 4): a map at the sensor limit
(LAMDE_MAX_SENSORS, 1,000) and one at the obstacle limit (LAMDE_MAX_OBSTACLES, 5,000) pass `check`
and `plan` (small budgets) under `ulimit -v` of 4 GB (RLIMIT_AS, set in the child), each child's
peak RSS under 2 GB. The vertex limit has the same test in tests/test_graph_memory.py.

The bounds are stated in `planner_core/defaults.py`'s docstring ("Memory at the input limits").
"""

from __future__ import annotations

import json
import math
import resource
import subprocess
import sys
from pathlib import Path

import pytest

from planner_core.textio import limit

ROOT = Path(__file__).resolve().parent.parent
TINY = ROOT / "tests" / "data" / "hostile" / "tiny-map.json"
GIB = 1024**3

#: what each child runs: the CLI's main, then its own peak RSS (KiB) on stdout
_CHILD = ("import resource, sys; from lamde_mission.cli import main; rc = main(sys.argv[1:]); "
          "print('maxrss_kib', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss); "
          "sys.exit(rc)")  # fmt: skip


def _cap() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (4 * GIB, 4 * GIB))


def _run_capped(args: list[str], timeout: float) -> tuple[subprocess.CompletedProcess, int]:
    """`lamde-mission ARGS` in a child under 4 GB of address space: (result, peak RSS bytes)."""
    r = subprocess.run([sys.executable, "-c", _CHILD, *args], capture_output=True, text=True,
                       timeout=timeout, preexec_fn=_cap, cwd=ROOT)  # fmt: skip
    assert "maxrss_kib" in r.stdout, (r.returncode, r.stderr[-3000:])
    rss = int(r.stdout.split("maxrss_kib")[1].split()[0]) * 1024
    return r, rss


def sensor_limit_map(path: Path) -> Path:
    """`generate --layout uniform`: 1,000 sensors (the default limit) on a 30 km map with its
    witness plan (feasible by construction, I_max 200)."""
    n = limit("sensors")
    r = subprocess.run([sys.executable, "-m", "lamde_mission.cli", "generate", str(path),
                        "--layout", "uniform", "--size", "30000", "--sensors", str(n),
                        "--seed", "1"], capture_output=True, text=True, timeout=600,
                       cwd=ROOT)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert len(json.loads(path.read_text())["sensors"]) == n == 1000
    return path


def obstacle_limit_map(path: Path) -> Path:
    """5,000 obstacles (the default limit): 2,500 circles and 2,500 rectangles on a grid 200 m
    apart on a 16 km map, with 8 sensors and the start and end in the open margin."""
    n = limit("obstacles")
    side = math.ceil(math.sqrt(n))
    w = 200 * side + 2000
    d = json.loads(TINY.read_text())
    d["area"] = {"width": w, "height": w}
    d["start"], d["end"] = [100, 100], [w - 100, w - 100]
    d["sensors"] = [{"id": f"s{k}", "x": 1000 + (w - 2000) * (k % 3) / 2,
                     "y": 1000 + (w - 2000) * (k // 3) / 2} for k in range(8)]  # fmt: skip
    circles, rects = [], []
    for k in range(n):
        cx, cy = 1100 + 200 * (k % side), 1100 + 200 * (k // side)
        if k % 2:
            circles.append({"x": cx, "y": cy, "radius": 30})
        else:
            rects.append({"x": cx, "y": cy, "length": 50, "width": 40, "angle_deg": 0})
    d["obstacles"] = {"circles": circles, "rectangles": rects}
    path.write_text(json.dumps(d))
    assert len(circles) + len(rects) == n == 5000
    return path


def _check_and_plan(src: Path, out: Path, plan_args: list[str],
                    plan_codes: tuple[int, ...] = (0,)) -> tuple[int, int]:
    """`check` then `plan` on `src`, each capped; their peak RSS (bytes). `plan_codes`: the
    exit statuses the plan may end with (1: infeasible, written with --allow-infeasible)."""
    r, rss_check = _run_capped(["check", str(src)], timeout=600)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    r, rss_plan = _run_capped(["plan", str(src), "-o", str(out), "--quiet", *plan_args],
                              timeout=900)  # fmt: skip
    assert r.returncode in plan_codes, r.stderr[-3000:]
    assert out.stat().st_size > 0
    mib = 2**20
    print(f"{src.name}: peak RSS check {rss_check / mib:.0f} MiB, plan {rss_plan / mib:.0f} MiB")
    return rss_check, rss_plan


@pytest.mark.slow(reason="measured 365 s wall on 2 cores under a load of 4 (the map's "
                  "generation included); peak RSS 213 MiB check, 706 MiB plan")  # fmt: skip
def test_a_map_at_the_sensor_limit_plans_under_4_gb(tmp_path: Path) -> None:
    src = sensor_limit_map(tmp_path / "s1000.json")
    # 200 evaluations leave some of 1,000 sensors unserved (exit 1): memory is what is held
    # here, so the plan is written anyway; the default budget plans it feasibly
    # (docs/scaling.md, "A thousand sensors")
    rss_check, rss_plan = _check_and_plan(
        src, tmp_path / "s1000.plan", ["--budget", "200", "--population", "20", "--starts", "1",
                                       "--no-descent", "--allow-infeasible"],
        plan_codes=(0, 1))  # fmt: skip
    assert rss_check < 2 * GIB and rss_plan < 2 * GIB, (rss_check, rss_plan)


@pytest.mark.slow(reason="measured 291 s wall on 2 loaded cores (~150 s of CPU, most of it "
                  "the seeder's visibility graph: every tangent pair tested against all 5,000 "
                  "obstacles; the budget does not shorten it); peak RSS 392 MiB check, 715 MiB "
                  "plan")  # fmt: skip
def test_a_map_at_the_obstacle_limit_plans_under_4_gb(tmp_path: Path) -> None:
    src = obstacle_limit_map(tmp_path / "o5000.json")
    rss_check, rss_plan = _check_and_plan(
        src, tmp_path / "o5000.plan", ["--budget", "200", "--population", "20", "--starts", "1",
                                       "--no-descent"])  # fmt: skip
    assert rss_check < 2 * GIB and rss_plan < 2 * GIB, (rss_check, rss_plan)

"""The executor seam without Ray running: backend choice, argument errors, bounded streaming of
the process pool, and Ray never imported unless its backend is chosen."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Iterator

import pytest

from planner_core.execution import ProcessExecutor, SerialExecutor, make_executor
from tests.conftest import SUITE, modules_after


def _hide_ray(monkeypatch: pytest.MonkeyPatch, present: bool = False) -> None:
    """Make `importlib.util.find_spec("ray")` say Ray is (not) installed, whatever it is;
    hidden, `import ray` fails too (as for an uninstalled module), so no Ray ever starts."""
    import importlib.machinery
    import importlib.util

    real = importlib.util.find_spec
    spec = importlib.machinery.ModuleSpec("ray", None) if present else None
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: spec if name == "ray" else real(name, *a))
    if not present:
        monkeypatch.setitem(sys.modules, "ray", None)


def test_make_executor_by_backend(monkeypatch: pytest.MonkeyPatch) -> None:
    assert isinstance(make_executor(0), SerialExecutor)
    ex = make_executor(2)
    assert isinstance(ex, ProcessExecutor) and ex.jobs == 2
    from planner_core.execution.ray_executor import RayExecutor

    _hide_ray(monkeypatch, present=True)  # found, never imported here
    ray_ex = make_executor(3, "ray", "ray://head:10001")
    assert isinstance(ray_ex, RayExecutor)  # built without importing or starting Ray
    assert (ray_ex.address, ray_ex.num_cpus) == ("ray://head:10001", 3)
    with pytest.raises(ValueError, match="backend must be one of local, ray"):
        make_executor(1, "dask")
    with pytest.raises(ValueError, match="only for the ray backend"):
        make_executor(1, "local", "auto")
    with pytest.raises(ValueError, match="jobs must be >= 0"):
        make_executor(-1, "ray")
    for backend in ("local", "ray"):  # a number no machine has: refused, nothing spawned
        with pytest.raises(ValueError, match="jobs must be at most 256"):
            make_executor(257, backend)
    _hide_ray(monkeypatch)
    with pytest.raises(ValueError, match=r"^backend ray: Ray is not installed; pip install "):
        make_executor(3, "ray", "ray://head:10001")


def test_run_bench_refuses_ray_missing_before_writing_anything(
        tmp_path, monkeypatch: pytest.MonkeyPatch) -> None:
    """run_bench(backend="ray") without Ray wrote meta.json, then failed in the executor on
    its first run (executor_problem did not look for Ray; make_executor built a RayExecutor
    that imports Ray only when it runs). The executor's one check now refuses it first."""
    from planner_core.bench import BenchError, run_bench
    from planner_core.execution import executor_problem

    _hide_ray(monkeypatch)
    assert executor_problem(0, "ray").startswith("backend ray: Ray is not installed; ")
    out = tmp_path / "o"
    with pytest.raises(BenchError, match=r"^backend ray: Ray is not installed; pip install "
                       r"'lamde-mission\[ray\]'"):
        run_bench(SUITE, ["random-search"], runs=1, budget=100, out=out, tasks=["T01"],
                  backend="ray", command="test", best_known=False)
    assert not out.exists()


@pytest.mark.slow  # measured 1.3 s on a loaded machine (default suite <= 5 min)
def test_ray_is_not_imported_by_the_planner_or_a_local_run() -> None:
    code = (
        "import lamde_mission.cli, lamde_mission.api, planner_core.bench, planner_core.execution\n"
        "from planner_core.execution import make_executor\n"
        "from planner_core.execution.ray_executor import RayExecutor\n"
        "RayExecutor('auto')\n"
        "import importlib.util\n"
        "if importlib.util.find_spec('ray'): make_executor(0, 'ray')\n"
        "with make_executor(0) as ex: assert list(ex.map_unordered(abs, [-1])) == [1]\n"
    )
    assert modules_after(code, "ray", timeout=120) == []


def test_process_executor_streams_with_a_bounded_number_in_flight() -> None:
    pulled = 0

    def items() -> Iterator[str]:
        nonlocal pulled
        for i in range(10):
            pulled += 1
            yield f"/a/b{i}"

    with ProcessExecutor(1) as ex:
        results = ex.map_unordered(os.path.basename, items())
        first = next(results)
        assert pulled <= 2  # 2 x jobs in flight, not the whole list
        assert sorted([first, *results]) == sorted(f"b{i}" for i in range(10))


def test_cli_backend_errors_exit_2(tmp_path, capsys, monkeypatch) -> None:
    from lamde_mission.cli import main

    base = ["bench", "--suite", str(SUITE), "--tasks", "T01", "--optimizers", "random-search",
            "--runs", "1", "--budget", "100", "--out", str(tmp_path / "o")]
    assert main([*base, "--address", "auto"]) == 2
    assert "--address: only with --backend ray" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:  # argparse's own choices check
        main([*base, "--backend", "dask"])
    assert exc.value.code == 2
    # Ray not installed: one line saying how to install it, before anything is written
    _hide_ray(monkeypatch)
    assert main([*base, "--backend", "ray"]) == 2
    assert "--backend ray: Ray is not installed; pip install 'lamde-mission[ray]'" in (
        capsys.readouterr().err)
    assert not (tmp_path / "o").exists()


def test_ray_init_arguments_per_address(monkeypatch) -> None:
    from planner_core.execution import SINGLE_THREAD_ENV
    from planner_core.execution.ray_executor import RayExecutor

    env = {"env_vars": SINGLE_THREAD_ENV}
    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    assert RayExecutor(num_cpus=2)._init_kwargs() == {
        "runtime_env": env, "include_dashboard": False, "num_cpus": 2}
    # a cluster: its own CPUs and dashboard; the Ray Client forwards every argument given
    assert RayExecutor("ray://head:10001", num_cpus=2)._init_kwargs() == {
        "runtime_env": env, "address": "ray://head:10001"}
    monkeypatch.setenv("RAY_ADDRESS", "auto")
    assert RayExecutor(num_cpus=2)._init_kwargs() == {"runtime_env": env}


def test_pool_initializer_sets_the_thread_limits() -> None:
    # In a fresh interpreter: numba's threading layer keeps the thread count it was launched
    # with, so launching it here under the initializer's limit would break later parallel
    # kernels of this test process once the environment is restored.
    code = """
import json, os, numba
from planner_core.execution import SINGLE_THREAD_ENV
from planner_core.execution.local import _init_worker
for k in SINGLE_THREAD_ENV:
    os.environ.pop(k, None)
numba.get_num_threads()
_init_worker(dict(SINGLE_THREAD_ENV))
print(json.dumps({"env": {k: os.environ[k] for k in SINGLE_THREAD_ENV},
                  "numba": numba.get_num_threads(), "want": SINGLE_THREAD_ENV}))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert got["env"] == got["want"]
    assert got["numba"] == 1  # numba was loaded already: capped at run time


_CTRL_C_WORKER = """
import os, signal, sys
import lamde_mission
from planner_core.execution.local import _init_worker
# the handler the worker starts with: the console script's (its spawned main module imports
# lamde_mission as `lamde-mission` does), or SIGINT ignored (a background job's)
signal.signal(signal.SIGINT, lamde_mission._quit_on_sigint if sys.argv[1] == "script"
              else signal.SIG_IGN)
_init_worker({})
os.kill(os.getpid(), signal.SIGINT)
print("still running")
"""


@pytest.mark.skipif(os.name != "posix", reason="a SIGINT sent with os.kill")
def test_a_worker_ends_quietly_on_ctrl_c_and_keeps_an_ignored_one() -> None:
    """`bench --jobs 2` stopped by Ctrl-C printed "lamde-mission: interrupted" three times: each
    worker (the console script's start-up handler, installed as the spawned worker re-imports
    the script) and the parent. The pool initializer now makes a worker end at once without a
    word (the parent says it, once); a SIGINT its parent ignored stays ignored."""
    def run(mode: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, "-c", _CTRL_C_WORKER, mode], capture_output=True,
                              text=True, timeout=120)

    r = run("script")
    assert (r.returncode, r.stdout, r.stderr) == (130, "", "")
    r = run("ignored")
    assert (r.returncode, r.stdout, r.stderr) == (0, "still running\n", "")


def _ctrl_c_self(_item: int) -> int:
    """A pool item that sends its worker a SIGINT, as a terminal's Ctrl-C reaches every
    process of the group; the worker's handler ends it before the sleep does."""
    import signal
    import time

    os.kill(os.getpid(), signal.SIGINT)
    time.sleep(60)
    return 0


@pytest.mark.skipif(os.name != "posix", reason="a SIGINT sent with os.kill")
def test_a_pool_worker_stopped_by_ctrl_c_ends_without_a_word(capfd) -> None:
    """In the pool, a Ctrl-C ends the worker (its run is lost, as the parent stops too)
    without a line or a traceback, rather than coming back to the parent as the item's
    KeyboardInterrupt."""
    from concurrent.futures.process import BrokenProcessPool

    ex = ProcessExecutor(1)
    try:
        try:
            list(ex.map_unordered(_ctrl_c_self, [0]))
            got = "returned"
        except BrokenProcessPool:
            got = "ended"
        except KeyboardInterrupt:  # the worker's, raised again here
            got = "KeyboardInterrupt"
    finally:
        ex.close()
    assert got == "ended"
    err = capfd.readouterr().err
    assert "interrupted" not in err and "Traceback" not in err, err


@pytest.mark.skipif(os.name != "posix", reason="POSIX re-parents orphans; Windows does not")
def test_pool_workers_end_when_their_parent_is_killed(tmp_path) -> None:
    """A parent killed outright (SIGKILL: no shutdown) leaves no worker running on: each
    watches its parent and ends within `PARENT_POLL_S` (before the fix they ran on with
    their item, here a 300 s sleep)."""
    import signal
    import time

    pids = tmp_path / "pids.txt"
    code = f"""
import os, time
from planner_core.execution import ProcessExecutor
ex = ProcessExecutor(2)
pool = ex._ensure_pool()
workers = [pool.submit(os.getpid).result() for _ in range(4)]
futs = [pool.submit(time.sleep, 300) for _ in range(2)]
time.sleep(0.5)
open({str(pids)!r}, "w").write(" ".join(map(str, sorted(set(workers)))))
time.sleep(300)
"""
    parent = subprocess.Popen([sys.executable, "-c", code])
    try:
        deadline = time.monotonic() + 120
        while not (pids.exists() and pids.read_text().strip()):
            assert time.monotonic() < deadline and parent.poll() is None, "no workers"
            time.sleep(0.2)
        workers = [int(p) for p in pids.read_text().split()]
        assert workers and all(_alive(p) for p in workers)
    finally:
        parent.send_signal(signal.SIGKILL)
        parent.wait()
    deadline = time.monotonic() + 30
    while any(_alive(p) for p in workers) and time.monotonic() < deadline:
        time.sleep(0.2)
    left = [p for p in workers if _alive(p)]
    for p in left:  # do not leave them behind if the test fails
        os.kill(p, signal.SIGKILL)
    assert not left, f"workers still running after their parent was killed: {left}"


def _alive(pid: int) -> bool:
    """Whether process `pid` runs (a zombie, dead but not reaped, counts as ended)."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False
    except OSError:
        try:
            os.kill(pid, 0)
        except OSError:
            return False
        return True

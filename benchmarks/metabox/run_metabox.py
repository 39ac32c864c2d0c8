"""Run MetaBox-v2's pretrained RLDE-AFL, GLEET and LDE on our maps, scored by our evaluator.

Runs with the MetaBox venv's interpreter (`benchmarks/metabox/setup.sh` makes it), never with
the project's: `metaevobox` needs numpy < 2. For each (agent, task, run) it starts
`evaluator_server.py` with the PROJECT's interpreter as a subprocess (README.md beside this
file), wraps the JSON-lines exchange as a MetaBox problem, loads the agent's pretrained
checkpoint shipped inside the `metaevobox` package (`metaevobox/model/bbob-10D/difficult/`) and
rolls it out as MetaBox's own Tester does (seeds, float64 default dtype, `rollout_episode`). The
server counts the budget and appends the run's record to OUT/results.jsonl; runs already there
are skipped, so an interrupted sweep resumes.

    /work/runs/metabox/venv/bin/python benchmarks/metabox/run_metabox.py \\
        --project-python .venv/bin/python --agents rlde-afl,gleet,lde \\
        --maps 'examples/maps/suite/T*.json' --runs 25 --out results-metabox

Importable without metaevobox (it is imported only when an agent is loaded): the parts that
talk to the server (`EvaluatorClient`, `ServerProblem`) are tested with the project's
interpreter in tests/test_protocols.py.
"""

from __future__ import annotations

import argparse
import copy
import glob
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
SERVER = HERE / "evaluator_server.py"
RESULTS_FILE = "results.jsonl"  # = planner_core.bench.records.RESULTS_FILE (not importable here)

#: our optimiser name -> (checkpoint file stem in metaevobox/model/<set>/<difficulty>/, class of
#: its backbone optimiser in metaevobox.environment.optimizer)
AGENTS: dict[str, tuple[str, str]] = {
    "rlde-afl": ("RLDEAFL", "RLDEAFL_Optimizer"),
    "gleet": ("GLEET", "GLEET_Optimizer"),
    "lde": ("LDE", "LDE_Optimizer"),
}
#: the checkpoints MetaBox-v2 ships: trained on BBOB 10-D, "difficult" split, maxFEs 20,000
CHECKPOINT_SET = ("bbob-10D", "difficult")
N_LOGPOINT = 50  # MetaBox's config.n_logpoint (its cost log; not used by our record)


class EvaluatorError(RuntimeError):
    """The evaluator server answered an error or died."""


class EvaluatorClient:
    """One `evaluator_server.py` subprocess: `info()`, `evaluate(X)`, `finish()` (README.md).

    `project_python`: the project's interpreter (numpy >= 2, planner_core importable);
    `server_args`: the server's command-line options (--map, --optimiser, --run, ...).
    """

    def __init__(self, project_python: str | Path, server_args: list[str],
                 cwd: str | Path | None = None) -> None:
        env = dict(os.environ)  # the server imports planner_core from this checkout
        env["PYTHONPATH"] = os.pathsep.join(
            [str(HERE.parents[1]), *filter(None, [env.get("PYTHONPATH")])])
        self.proc = subprocess.Popen([str(project_python), str(SERVER), *server_args],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                     cwd=cwd, env=env)

    def request(self, obj: dict[str, Any]) -> dict[str, Any]:
        assert self.proc.stdin is not None and self.proc.stdout is not None
        try:
            self.proc.stdin.write(json.dumps(obj) + "\n")
            self.proc.stdin.flush()
        except BrokenPipeError:
            raise EvaluatorError(f"evaluator exited (status {self.proc.poll()})") from None
        line = self.proc.stdout.readline()
        if not line:
            raise EvaluatorError(f"evaluator exited (status {self.proc.wait()})")
        reply = json.loads(line)
        if "error" in reply:
            raise EvaluatorError(reply["error"])
        return reply

    def info(self) -> dict[str, Any]:
        return self.request({"op": "info"})

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        """Penalised scores f + 10 phi of the rows of X (problem space), shape (n,)."""
        return np.asarray(self.request({"op": "evaluate", "X": np.asarray(X).tolist()})["score"],
                          dtype=float)

    def finish(self) -> dict[str, Any]:
        rec = self.request({"op": "finish"})["record"]
        self.proc.wait(timeout=60)
        return rec

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


class ServerProblem:
    """Our map as a MetaBox problem (the duck type of metaevobox's `Basic_Problem`): `dim`, `lb`,
    `ub` (arrays, problem space), `optimum` None (unknown), `eval(x)` -> penalised scores (one
    row -> float, rows -> array), `T1` the evaluation time in ms as MetaBox keeps it."""

    def __init__(self, client: EvaluatorClient, info: dict[str, Any], name: str) -> None:
        self.client = client
        self.dim = int(info["dim"])
        self.lb = np.asarray(info["lower"], dtype=float)
        self.ub = np.asarray(info["upper"], dtype=float)
        self.optimum = None
        self.name = name
        self.T1 = 0.0

    def reset(self) -> None:
        self.T1 = 0.0

    def eval(self, x: Any) -> Any:
        t0 = time.perf_counter()
        x = np.asarray(x, dtype=float)
        y = self.client.evaluate(x.reshape(-1, x.shape[-1]))
        self.T1 += (time.perf_counter() - t0) * 1000
        return y[0] if x.ndim == 1 else y

    def __str__(self) -> str:
        return self.name


def done_keys(out: Path) -> set[tuple[str, str, int]]:
    """(optimiser, task, run) of the uniform-start records already in OUT/results.jsonl."""
    keys: set[tuple[str, str, int]] = set()
    path = out / RESULTS_FILE
    if path.exists():
        for line in path.read_text().splitlines():
            try:
                r = json.loads(line)
                keys.add((r["optimiser"], r["task"], int(r["run"])))
            except (ValueError, KeyError, TypeError):
                continue  # a truncated tail: that run is redone
    return keys


def load_agent(name: str) -> tuple[Any, Any]:
    """(pretrained agent, backbone optimiser class) of `name` from the installed metaevobox."""
    import importlib.resources as resources
    import pickle

    import metaevobox.environment.optimizer as mopt

    stem, opt_class = AGENTS[name]
    ref = resources.files("metaevobox").joinpath("model", *CHECKPOINT_SET, f"{stem}.pkl")
    with ref.open("rb") as f:
        agent = pickle.load(f)
    for obj in (agent, getattr(agent, "config", None)):
        if obj is not None and hasattr(obj, "device"):
            obj.device = "cpu"  # the checkpoints may record a GPU; we run on the CPU
    return agent, getattr(mopt, opt_class)


def run_one(name: str, agent: Any, opt_class: Any, map_path: Path, run: int, args: Any) -> dict:
    """One rollout of `agent` on `map_path`; returns the server's record (also in OUT)."""
    import torch
    from metaevobox.environment.basic_environment import PBO_Env

    task = map_path.stem
    client = EvaluatorClient(args.project_python, [
        "--map", str(map_path), "--optimiser", name, "--run", str(run),
        "--base-seed", str(args.seed), "--budget", str(args.budget), "--init", "uniform",
        "--out", str(args.out)])
    try:
        info = client.info()
        seed = int(info["seed"])
        problem = ServerProblem(client, info, task)
        config = SimpleNamespace(maxFEs=args.budget, n_logpoint=N_LOGPOINT,
                                 log_interval=args.budget // N_LOGPOINT, full_meta_data=False,
                                 device="cpu", seed=seed)
        env = PBO_Env(problem, opt_class(config))
        # as metaevobox.tester.Tester.test (serial mode) seeds and rolls out one test run
        torch.manual_seed(seed)
        np.random.seed(seed)  # noqa: NPY002 (MetaBox's operators draw from the legacy global RNG)
        torch.set_default_dtype(torch.float64)
        res = copy.deepcopy(agent).rollout_episode(env, seed, {})
        rec = client.finish()
        rec["metabox_fes"] = int(res["fes"])  # for the log line only; not written to OUT
        return rec
    finally:
        client.close()


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--project-python", required=True,
                    help="the project's interpreter (runs evaluator_server.py)")
    ap.add_argument("--agents", default=",".join(AGENTS),
                    help=f"comma-separated, of {', '.join(AGENTS)} (default: all)")
    ap.add_argument("--maps", default="examples/maps/suite/T*.json", help="glob of map files")
    ap.add_argument("--runs", type=int, default=25, help="runs 0..RUNS-1 per (agent, map)")
    ap.add_argument("--seed", type=int, default=0,
                    help="base seed: run r on task t uses run_seed(SEED, t, r), as our bench")
    ap.add_argument("--budget", type=int, default=10_000)
    ap.add_argument("--out", required=True, help="folder of results.jsonl (appended, resumable)")
    ap.add_argument("--threads", type=int, default=1, help="torch threads (default 1)")
    a = ap.parse_args(argv)
    a.agents = [s.strip() for s in a.agents.split(",") if s.strip()]
    bad = [s for s in a.agents if s not in AGENTS]
    if bad:
        ap.error(f"--agents: unknown {', '.join(bad)} (have {', '.join(AGENTS)})")
    a.map_files = [Path(p) for p in sorted(glob.glob(a.maps))]
    if not a.map_files:
        ap.error(f"--maps: no file matches {a.maps!r}")
    if a.runs < 1 or a.budget < 1:
        ap.error("--runs and --budget must be >= 1")
    a.out = Path(a.out)
    return a


def main(argv: list[str] | None = None) -> int:
    a = parse_args(argv)
    import torch

    torch.set_num_threads(a.threads)
    a.out.mkdir(parents=True, exist_ok=True)
    have = done_keys(a.out)
    # run-major: a sweep cut short still covers every (agent, map) with the same runs
    for run in range(a.runs):
        for name in a.agents:
            agent, opt_class = load_agent(name)
            for m in a.map_files:
                if (name, m.stem, run) in have:
                    continue
                t0 = time.perf_counter()
                rec = run_one(name, agent, opt_class, m, run, a)
                print(f"{name} {m.stem} run {run}: score {rec['score']:.2f} feasible "
                      f"{rec['feasible']} evaluations {rec['evaluations']} (MetaBox fes "
                      f"{rec['metabox_fes']}) {time.perf_counter() - t0:.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Meta-training's rollouts behind the executor (planner_core.learning.policy.rollout): a segment
is a
function of its job alone (continuing an episode from a carry equals running it in one go; the
logged log-probabilities are the network's), jobs carry no paths, the workers never import torch,
and the same seed gives the same checkpoint in this process and on two worker processes. The
same check on a local Ray instance is in test_execution_ray.py."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import numpy as np
import pytest

from planner_core.learning.policy import NetConfig, init_params, log_prob
from planner_core.learning.policy.network import forward, param_shapes
from planner_core.learning.policy.rollout import (
    EpisodeKey,
    SegmentJob,
    collect,
    portable_spec,
    run_segment,
)
from tests.conftest import HAND_MAP, MAPS, modules_after

NET = NetConfig(embed=8, heads=2, ff=12, hidden=10)
TINY_SPECS = [{"kind": "map", "path": str(MAPS / "tiny.json")}, {"kind": "map", "map": HAND_MAP}]


def _weights(seed: int) -> dict[str, np.ndarray]:
    """Weights with every head non-zero (init_params zeroes the actor heads)."""
    rng = np.random.default_rng(seed)
    return {k: rng.normal(0.0, 0.5, s).astype(np.float32) for k, s in param_shapes(NET).items()}


def _job(n_steps: int, index: int = 0, init: str = "uniform") -> SegmentJob:
    return SegmentJob(key=EpisodeKey(5, 1, index), spec=portable_spec(TINY_SPECS[0]), init=init,
                      population=8, budget=64, eta=10.0, delta=1e-8, n_steps=n_steps,
                      net=NET.to_dict(), weights=_weights(3))


def test_a_segment_continued_from_its_carry_equals_one_long_segment() -> None:
    whole = run_segment(_job(7))  # G = 7 generations: the whole episode
    assert whole.done and whole.steps == 7 and whole.next_value == 0.0
    assert whole.dones.tolist() == [0.0] * 6 + [1.0]
    parts = [run_segment(_job(3))]
    while not parts[-1].done:
        job = _job(3)
        job.carry = pickle.loads(pickle.dumps(parts[-1].carry))  # as a remote worker gets it
        parts.append(run_segment(job))
    assert [p.steps for p in parts] == [3, 3, 1]
    for name in ("X", "f", "phi", "progress", "actions", "logp", "values", "rewards", "dones"):
        np.testing.assert_array_equal(np.concatenate([getattr(p, name) for p in parts]),
                                      getattr(whole, name), err_msg=name)
    assert (parts[-1].best_f, parts[-1].best_phi) == (whole.best_f, whole.best_phi)
    # the bootstrap value of a cut segment is V of the next segment's first state
    assert parts[0].next_value == pytest.approx(parts[1].values[0], abs=1e-12)
    # another episode index draws another DE seed and other actions
    other = run_segment(_job(3, index=1))
    assert not np.array_equal(other.X[0], parts[0].X[0])


def test_segment_log_probs_and_values_are_the_networks() -> None:
    seg = run_segment(_job(2))
    for t in range(seg.steps):
        out = forward(_weights(3), NET, seg.obs(t))
        a = seg.actions[t]
        want = log_prob(out, a[:, 0].astype(np.intp), a[:, 1].astype(np.intp),
                        a[:, 2].astype(float), a[:, 3].astype(float))
        np.testing.assert_allclose(seg.logp[t], want, rtol=1e-6)
        assert seg.values[t] == pytest.approx(out.value, abs=1e-6)
        assert np.all((a[:, 2] > 0) & (a[:, 2] < 1) & (a[:, 3] > 0) & (a[:, 3] < 1))


def test_jobs_carry_map_content_not_paths(tmp_path: Path) -> None:
    spec = portable_spec(TINY_SPECS[0])
    assert spec == {"kind": "map", "map": json.loads((MAPS / "tiny.json").read_text())}
    assert portable_spec(TINY_SPECS[1]) is TINY_SPECS[1]
    assert str(MAPS) not in pickle.dumps(_job(1)).decode("latin-1")
    with pytest.raises(ValueError, match="none.json: file not found"):  # textio's words
        portable_spec({"kind": "map", "path": str(tmp_path / "none.json")})


def test_collect_returns_segments_in_job_order() -> None:
    jobs = [_job(2, index=i) for i in range(3)]

    class Reversed:
        def map_unordered(self, fn, items):  # noqa: ANN001, ANN202
            return (fn(item) for item in reversed(list(items)))

    segs = collect(Reversed(), jobs)
    assert [s.key.index for s in segs] == [0, 1, 2]
    with pytest.raises(ValueError, match="same episode"):
        collect(Reversed(), [jobs[0], jobs[0]])


@pytest.mark.slow  # measured 4 s (issue 35: default suite <= 5 min)
def test_rollout_workers_never_import_torch() -> None:
    code = (
        "from tests.test_rollout import _job\n"
        "from planner_core.learning.policy.rollout import run_segment\n"
        "assert run_segment(_job(2)).steps == 2\n"
    )
    assert modules_after(code, "torch") == []


#: a 2-epoch training of 2 tiny maps in chunks of 2 episodes, 3-generation segments
TRAIN_ARGS = ["--epochs", "2", "--envs", "2", "--population", "8", "--budget", "64", "--seed",
              "4", "--set", "n_steps=3", "--set", "net.embed=8", "--set", "net.heads=2",
              "--set", "net.ff=12", "--set", "net.hidden=10", "--quiet"]


def train_cli(tmp_path: Path, name: str, *extra: str) -> Path:
    """`lamde-mission train` on TINY_SPECS with TRAIN_ARGS and ``extra``; the checkpoint."""
    from lamde_mission.cli import main

    problems = tmp_path / "trainset.json"
    problems.write_text(json.dumps({"problems": TINY_SPECS}))
    assert main(["train", "-o", str(tmp_path / name), "--problems", str(problems), *TRAIN_ARGS,
                 *extra]) == 0
    return tmp_path / name


def assert_same_checkpoint(a: Path, b: Path) -> None:
    """Same weights and manifest, same curve (its last column, seconds, aside)."""
    for name in ("weights.npz", "manifest.json"):
        assert (a / name).read_bytes() == (b / name).read_bytes(), name

    def curve(p: Path) -> list[list[str]]:
        return [ln.split(",")[:-1] for ln in (p / "curve.csv").read_text().splitlines()]

    assert curve(a) == curve(b)


@pytest.mark.slow  # measured 11 s (issue 35: default suite <= 5 min)
def test_same_seed_same_checkpoint_in_this_process_and_on_two_workers(tmp_path: Path) -> None:
    pytest.importorskip("torch")
    here = train_cli(tmp_path, "here")  # --jobs 1 (the default): rollouts in this process
    pool = train_cli(tmp_path, "pool", "--jobs", "2")  # on two worker processes
    assert_same_checkpoint(here, pool)
    # and training moved the weights away from their initialisation
    trained = dict(np.load(here / "weights.npz"))
    start = init_params(NET, 4)
    assert set(trained) == set(start)
    assert any(not np.array_equal(trained[k], start[k]) for k in start)


def test_cli_train_executor_errors_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    pytest.importorskip("torch")
    from lamde_mission.cli import main

    out = tmp_path / "ck"
    assert main(["train", "-o", str(out), "--jobs", "0"]) == 2
    assert "--jobs: must be >= 1" in capsys.readouterr().err
    assert main(["train", "-o", str(out), "--address", "auto"]) == 2
    assert "--address: only with --backend ray" in capsys.readouterr().err
    assert not out.exists()

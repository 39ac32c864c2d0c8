"""Rollout workers of meta-training: the actor side of an actor/learner split (no torch here).

The learner (:func:`planner_core.learning.policy.ppo.train`, torch, in the driver) owns the weights
and
the PPO update. Everything an episode needs between two updates is one :class:`SegmentJob`,
which any executor (:mod:`planner_core.execution`: this process, a local process pool, Ray) runs
with :func:`run_segment`:

    job (problem spec with its map's content, start mode, episode key, numpy weights,
         the DE state and action generator left by the previous segment)
      -> up to n DE generations (planner_core.learning.env.OptimizationEnv), each acting with the
         numpy forward pass (planner_core.learning.policy.network.forward) and sample_actions
      -> Segment (obs, actions, log pi(a|s), V(s), rewards, dones, V of the next state,
         and the DE state and generator to continue from)

A job is complete in itself: no file paths (map specs carry the map's JSON, see
:func:`portable_spec`), no handle to the driver, nothing stored in the worker that changes the
result (each worker keeps built problems in a small cache, a pure function of the spec). So a
segment's result depends only on its job, and training gives the same checkpoint whichever
backend and however many workers run the segments.

Seeds: episode ``j`` of epoch ``e`` of a training with seed ``s`` draws from its own generator,
``numpy.random.default_rng(SeedSequence(s, spawn_key=(e, j)))``: first the DE run's reset seed
(one ``integers(2**62)``), then every action of the episode (:func:`sample_actions`' order),
generation after generation; the generator travels with the episode from segment to segment.

Workers run numeric code single-threaded (the executors set BLAS/OpenMP/numba thread limits).
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from planner_core.learning.env import OptimizationEnv, observe
from planner_core.learning.policy.network import NetConfig, forward, log_prob, sample_actions
from planner_core.learning.policy.problems import build, read_json_file
from planner_core.search.de.types import DEState
from planner_core.search.init_modes import with_init

__all__ = [
    "Carry",
    "EpisodeKey",
    "Segment",
    "SegmentJob",
    "collect",
    "episode_rng",
    "portable_spec",
    "problem_of",
    "run_segment",
]

#: built problems kept per worker process (a training set's problems are reused every epoch)
PROBLEM_CACHE = 64


def portable_spec(spec: dict[str, Any]) -> dict[str, Any]:
    """``spec`` as a job can carry it to any machine: a ``{"kind": "map", "path": p}`` spec
    becomes ``{"kind": "map", "map": <p's JSON content>}``; every other spec is returned as is.

    Args:
        spec: a problem spec.

    Returns:
        The portable spec (``spec`` itself when nothing is to read).

    Raises:
        ValueError: naming the path when the file is missing or not JSON.
    """
    if spec.get("kind") != "map" or "map" in spec or "path" not in spec:
        return spec
    return {"kind": "map", "map": read_json_file(Path(spec["path"]), "problems")}


@lru_cache(maxsize=PROBLEM_CACHE)
def _built(key: str) -> Any:
    return build(json.loads(key))


def problem_of(spec: dict[str, Any]) -> Any:
    """The problem of ``spec`` (:func:`planner_core.learning.policy.problems.build`), built once
    per process and spec (a cache of ``PROBLEM_CACHE`` problems).

    Args:
        spec: a JSON-able problem spec.

    Returns:
        The built problem (shared by later calls with an equal spec).

    Raises:
        ValueError: as ``build`` raises it.
    """
    return _built(json.dumps(spec, sort_keys=True))


@dataclass(frozen=True)
class EpisodeKey:
    """Which episode: training seed, epoch and the episode's index within the epoch."""

    seed: int
    epoch: int
    index: int


def episode_rng(key: EpisodeKey) -> np.random.Generator:
    """The episode's own generator (module docstring, "Seeds").

    Args:
        key: the episode (training seed, epoch, index).

    Returns:
        ``default_rng(SeedSequence(seed, spawn_key=(epoch, index)))``.
    """
    return np.random.default_rng(np.random.SeedSequence(key.seed,
                                                        spawn_key=(key.epoch, key.index)))


@dataclass
class Carry:
    """Where an episode stands between two segments: the DE state and the action generator."""

    state: DEState
    rng: np.random.Generator


@dataclass
class SegmentJob:
    """One episode's next n generations (everything a remote worker needs).

    ``spec``: a portable problem spec (:func:`portable_spec`); ``init``: start mode;
    ``weights``: the policy's numpy parameters (float32, :func:`network.param_shapes` names);
    ``net``: NetConfig fields; ``carry``: None for the episode's first segment (the DE is reset
    with a seed from :func:`episode_rng`), else the previous segment's ``carry``.
    """

    key: EpisodeKey
    spec: dict[str, Any]
    init: str
    population: int
    budget: int
    eta: float
    delta: float
    n_steps: int
    net: dict[str, int]
    weights: dict[str, np.ndarray]
    carry: Carry | None = None


@dataclass
class Segment:
    """T <= n generations of one episode (N = population, d = dimension).

    Observations as the learner batches them (float32): ``X`` (T, N, d), ``f`` and ``phi`` (T,
    N, 2), ``progress`` (T,), ``context`` (T, K); ``actions`` (T, N, 4) float32 (mutation id,
    crossover id, F, Cr: exactly what the DE ran); ``logp`` (T, N) log pi(a_i|s) per individual
    and ``values`` (T,) V(s), both under the job's weights; ``rewards`` and ``dones`` (T,);
    ``next_value``: V of the state after the segment (0.0 when the episode ended); ``carry``:
    None when the episode ended; ``best_f``, ``best_phi``: the Deb-best after the segment;
    ``cpu_s`` and ``wall_s``: the worker's time for the segment (problem build included on a
    cache miss).
    Per-individual credit (the env's info, :func:`planner_core.learning.env.trial_credit`):
    ``credits`` (T, N), ``parent_feasible`` (T, N) bool and ``population_credit`` (T,).
    """

    key: EpisodeKey
    X: np.ndarray
    f: np.ndarray
    phi: np.ndarray
    progress: np.ndarray
    actions: np.ndarray
    logp: np.ndarray
    values: np.ndarray
    rewards: np.ndarray
    dones: np.ndarray
    context: np.ndarray
    credits: np.ndarray
    parent_feasible: np.ndarray
    population_credit: np.ndarray
    next_value: float
    carry: Carry | None
    best_f: float
    best_phi: float
    cpu_s: float = 0.0
    wall_s: float = 0.0
    steps: int = field(init=False)

    def __post_init__(self) -> None:
        self.steps = int(self.rewards.shape[0])

    @property
    def done(self) -> bool:
        """Whether the episode ended with this segment.

        Returns:
            True when ``carry`` is None.
        """
        return self.carry is None

    def obs(self, t: int) -> dict[str, np.ndarray]:
        """The observation of step ``t`` in the env's layout
        (:func:`planner_core.learning.env.observe`).

        Args:
            t: the step, 0..steps - 1.

        Returns:
            {"X" (N, d), "f" (N, 2), "phi" (N, 2), "progress" (1,), "context" (K,)}, views
            of the segment's arrays.
        """
        return {"X": self.X[t], "f": self.f[t], "phi": self.phi[t],
                "progress": self.progress[t:t + 1], "context": self.context[t]}


def run_segment(job: SegmentJob) -> Segment:
    """Run up to ``job.n_steps`` generations of the job's episode with the job's weights.

    Args:
        job: the segment's job (a first segment resets the DE, a later one continues from
            ``job.carry``).

    Returns:
        The `Segment` (``carry`` None when the episode ended).

    Raises:
        ValueError: a bad spec or start mode (from building the problem), or network sizes
            `NetConfig` refuses.
    """
    c0, w0 = time.process_time(), time.perf_counter()
    cfg = NetConfig(**job.net)
    problem = with_init(problem_of(job.spec), job.init)
    if job.carry is None:
        rng = episode_rng(job.key)
        env = OptimizationEnv(population=job.population, budget=job.budget, eta=job.eta,
                              delta=job.delta)
        obs, _ = env.reset(seed=int(rng.integers(2**62)), options={"problem": problem})
    else:
        rng = job.carry.rng
        env = OptimizationEnv(problem, population=job.population, budget=job.budget,
                              eta=job.eta, delta=job.delta)
        env.state = job.carry.state
        obs = observe(env.state, job.eta)
    buf: dict[str, list[Any]] = {k: [] for k in (
        "X", "f", "phi", "progress", "actions", "logp", "values", "rewards", "dones",
        "context", "credits", "parent_feasible", "population_credit")}
    done = False
    for _ in range(job.n_steps):
        out = forward(job.weights, cfg, obs)
        # the action as float32 is the action: the DE runs it and the learner scores it
        a = np.stack(sample_actions(out, rng), axis=1).astype(np.float32)
        mutation, crossover = a[:, 0].astype(np.intp), a[:, 1].astype(np.intp)
        F, Cr = a[:, 2].astype(np.float64), a[:, 3].astype(np.float64)
        buf["X"].append(np.asarray(obs["X"], dtype=np.float32))
        buf["f"].append(np.asarray(obs["f"], dtype=np.float32))
        buf["phi"].append(np.asarray(obs["phi"], dtype=np.float32))
        buf["progress"].append(np.float32(obs["progress"][0]))
        buf["context"].append(np.asarray(obs["context"], dtype=np.float32))
        buf["actions"].append(a)
        buf["logp"].append(log_prob(out, mutation, crossover, F, Cr).astype(np.float32))
        buf["values"].append(out.value)
        obs, r, term, trunc, info = env.step((mutation, crossover, F, Cr))
        done = bool(term or trunc)
        buf["rewards"].append(r)
        buf["credits"].append(info["credit"])
        buf["parent_feasible"].append(info["parent_feasible"])
        buf["population_credit"].append(info["population_credit"])
        buf["dones"].append(float(done))
        if done:
            break
    next_value = 0.0 if done else forward(job.weights, cfg, obs).value
    state = env.state
    wide = ("values", "rewards", "dones", "credits", "population_credit")
    arrays = {k: np.asarray(v, dtype=bool if k == "parent_feasible" else
                            np.float64 if k in wide else np.float32) for k, v in buf.items()}
    return Segment(key=job.key, **arrays, next_value=float(next_value),
                   carry=None if done else Carry(state, rng),
                   best_f=float(state.best_f), best_phi=float(state.best_phi),
                   cpu_s=time.process_time() - c0, wall_s=time.perf_counter() - w0)


def collect(executor: Any, jobs: Iterable[SegmentJob]) -> list[Segment]:
    """Run ``jobs`` on ``executor`` and return the segments in the jobs' order, whatever order
    they finished in.

    Args:
        executor: a :class:`planner_core.execution.Executor`.
        jobs: the segment jobs, one per episode.

    Returns:
        The segments, in the jobs' order.

    Raises:
        ValueError: two jobs for the same episode.
        RuntimeError: no segment came back for a job.
    """
    jobs = list(jobs)
    rows = {job.key: i for i, job in enumerate(jobs)}
    if len(rows) != len(jobs):
        raise ValueError("collect: two jobs for the same episode")
    out: list[Segment | None] = [None] * len(jobs)
    for seg in executor.map_unordered(run_segment, jobs):
        out[rows[seg.key]] = seg
    missing = [job.key for job, seg in zip(jobs, out, strict=True) if seg is None]
    if missing:
        raise RuntimeError(f"collect: no segment came back for {missing}")
    return out  # type: ignore[return-value]

"""Behaviour cloning: a warm start of the policy from a hand-made configurator (training only;
this module is numpy only: the demonstrations and the reward scaling; the maximum-likelihood fit
is :func:`planner_core.learning.policy.ppo.pretrain`).

Before PPO, :func:`collect_demos` runs the DE driven by a hand-made configurator (by default
``adaptive``, :class:`planner_core.search.de.configurators.AdaptiveConfigurator`) on every training
problem in every start mode, with the training population and budget, and records for every
``stride``-th generation the env's observation (:func:`planner_core.learning.env.observe`, exactly
what
the policy sees), the configurator's per-individual choice (mutation id, crossover id, F, Cr;
F and Cr clipped to ``[RATE_EPS, 1 - RATE_EPS]`` where the Beta's density is finite) and the
discounted return-to-go of the paper's reward (:func:`planner_core.learning.env.reward`, scaled per
episode as PPO scales it, :class:`RewardScaler`).

:func:`planner_core.learning.policy.ppo.pretrain` then fits the actor by maximum likelihood (the
mean
negative exact log-probability of the demonstrated actions, the same factorised distribution PPO
samples from) and the critic by least squares on the returns-to-go:

    L_BC = -mean over (generation, individual) of log pi(a_i | s) + c_V 0.5 mean (V(s) - G)^2

in ``imitate_epochs`` passes of Adam (``imitate_lr``) over shuffled mini-batches of
``imitate_batch`` observations, gradient norm clipped as in PPO.

The imitated configurator keeps a memory (arm qualities, stall count) that the policy does not
observe: the policy can only learn what the configurator does on average in a state like this,
which is the point of a warm start, not the end of training.

Determinism: the demo episodes' DE seeds come from ``SeedSequence(seed, spawn_key=(DEMO_KEY,
problem, mode))`` and the mini-batch order from ``default_rng([seed, DEMO_KEY, epoch])``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner_core.learning.env import observe, reward
from planner_core.learning.policy.network import RATE_EPS
from planner_core.search.de import make_configurator
from planner_core.search.de.core import init, step
from planner_core.search.de.rng import Streams
from planner_core.search.init_modes import with_init

#: spawn-key namespace of the demonstration episodes (PPO's episodes use small epoch numbers)
DEMO_KEY = 1_000_003


class RewardScaler:
    """Reward scaling per training problem (and start mode), as CleanRL's ``NormalizeReward``:
    each reward is divided by the running standard deviation of that problem's discounted
    return ``R_t = gamma R_{t-1} + r_t`` (not re-centred), then clipped to [-clip, clip].

    Why: the env's reward is relative (fractions of the violation or objective gained, plus a
    one-off bonus of 1-2 for reaching feasibility), but its scale still differs by orders of
    magnitude between a seeded episode (improvements of 1e-4) and a uniform start on a large
    map (violation halved every few generations); without scaling, the batch-normalised
    advantage is dominated by the latter. A key is e.g. ``"uav-5000-d1-s7000/uniform"``.

    State (:meth:`state_dict`) is saved with the training state, so ``resume`` continues it.
    """

    def __init__(self, gamma: float, clip: float = 10.0, eps: float = 1e-8) -> None:
        self.gamma, self.clip, self.eps = float(gamma), float(clip), float(eps)
        self.stats: dict[str, list[float]] = {}  # key -> [count, mean, M2] of R_t
        self.running: dict[str, float] = {}  # key -> current episode's R_t

    def reset(self, key: str) -> None:
        """A new episode of ``key`` starts (its discounted return restarts at 0).

        Args:
            key: the episode key, e.g. ``"uav-5000-d1-s7000/uniform"``.
        """
        self.running[key] = 0.0

    def scale(self, key: str, rewards: np.ndarray) -> np.ndarray:
        """Scale the consecutive rewards (T,) of one episode of ``key``: first update the
        running statistics with their discounted returns (Welford), then divide by the std
        (population std of R_t; 1 until two returns are seen) plus ``eps``.

        Args:
            key: the episode key.
            rewards: (T,) rewards, in order.

        Returns:
            (T,) scaled rewards, clipped to [-clip, clip].
        """
        R = self.running.get(key, 0.0)
        n, mean, m2 = self.stats.get(key, [0.0, 0.0, 0.0])
        for r in np.asarray(rewards, dtype=float):
            R = self.gamma * R + r
            n += 1.0
            delta = R - mean
            mean += delta / n
            m2 += delta * (R - mean)
        self.running[key] = R
        self.stats[key] = [n, mean, m2]
        std = math.sqrt(m2 / n) if n > 1 else 1.0
        return np.clip(np.asarray(rewards, dtype=float) / (std + self.eps), -self.clip, self.clip)

    def state_dict(self) -> dict[str, Any]:
        """The scaler's state, for the training state (``resume``).

        Returns:
            {"stats": {key: [count, mean, M2]}, "running": {key: R_t}} (shallow copies).
        """
        return {"stats": dict(self.stats), "running": dict(self.running)}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore the state of :meth:`state_dict` (missing parts: empty).

        Args:
            state: a :meth:`state_dict` object.
        """
        self.stats = {k: list(v) for k, v in state.get("stats", {}).items()}
        self.running = dict(state.get("running", {}))


@dataclass
class Demos:
    """Recorded generations: ``obs`` (list of env observations), ``actions`` (S, N, 4) float32
    (mutation id, crossover id, F, Cr), ``returns`` (S,) scaled discounted returns-to-go,
    ``names`` (S,) the episode key of each sample."""

    obs: list[dict[str, np.ndarray]]
    actions: np.ndarray
    returns: np.ndarray
    names: list[str]


def demo_episode(
    problem: Any,
    configurator: Any,
    seed: int,
    population: int,
    budget: int,
    eta: float,
    delta: float,
) -> tuple[list[dict[str, np.ndarray]], np.ndarray, np.ndarray]:
    """One DE run driven by ``configurator`` (memory kept, as :func:`planner_core.search.de.run`).

    Args:
        problem: the box problem (in its start mode's wrapper).
        configurator: the hand-made configurator (``init``, ``configure``, ``update``).
        seed: the run's DE seed.
        population: N.
        budget: evaluations.
        eta: the observation's exponent scale.
        delta: the reward's feasibility tolerance.

    Returns:
        (observations, actions, rewards): the observation before every generation, the
        configuration it chose (G, N, 4) float32 (mutation id, crossover id, F, Cr; F and Cr
        clipped to [RATE_EPS, 1 - RATE_EPS]; a last generation of fewer trials padded with its
        last row) and the env's reward of that generation (G,).
    """
    state = init(problem, seed, population, budget)
    state = dataclasses.replace(state, memory=configurator.init(state))
    streams = Streams(state.seed)
    obs, acts, rews = [], [], []
    while not state.done:
        o = observe(state, eta)
        prev = state
        state, out = step(state, problem, configurator, streams)
        c = out.config
        k = len(c.mutation)
        a = np.stack([np.asarray(c.mutation, float), np.asarray(c.crossover, float),
                      np.clip(np.asarray(c.F, float), RATE_EPS, 1 - RATE_EPS),
                      np.clip(np.asarray(c.Cr, float), RATE_EPS, 1 - RATE_EPS)], axis=1)
        if k < population:  # the budget's last generation may configure fewer trials
            a = np.concatenate([a, np.repeat(a[-1:], population - k, axis=0)])
        obs.append(o)
        acts.append(a)
        rews.append(reward(prev.best_phi, prev.best_f, state.best_phi, state.best_f,
                           state.generation / max(state.max_generations, 1), delta))
    return obs, np.asarray(acts, dtype=np.float32), np.asarray(rews)


def collect_demos(
    problems: list[Any],
    names: list[str],
    *,
    configurator: str,
    init_modes: tuple[str, ...],
    seed: int,
    population: int,
    budget: int,
    gamma: float,
    eta: float,
    delta: float,
    stride: int = 1,
    scaler: RewardScaler | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Demos:
    """Demonstrations of ``configurator`` on every problem x start mode (see module doc).

    Args:
        problems: the training problems.
        names: their names (episode key ``name/mode``).
        configurator: the hand-made configurator's name (`make_configurator`).
        init_modes: start modes.
        seed: the base seed of the episodes' DE seeds.
        population: N.
        budget: evaluations per episode.
        gamma: discount of the returns-to-go (and of a fresh scaler).
        eta: the observation's exponent scale.
        delta: the reward's feasibility tolerance.
        stride: every ``stride``-th generation is kept, >= 1.
        scaler: scales the rewards (keys ``name/mode``) before the returns-to-go are taken;
            None: a fresh ``RewardScaler(gamma)`` (statistics per episode key).
        progress: ``progress(done, total)`` after each episode.

    Returns:
        The `Demos`.

    Raises:
        ValueError: stride < 1, an unknown configurator or start mode, or no problems.
    """
    if stride < 1:
        raise ValueError(f"imitate_stride: must be >= 1, got {stride}")
    conf = make_configurator(configurator)
    scaler = RewardScaler(gamma) if scaler is None else scaler
    obs_all: list[dict[str, np.ndarray]] = []
    acts_all, rets_all, keys = [], [], []
    total = len(problems) * len(init_modes)
    for i, (problem, name) in enumerate(zip(problems, names, strict=True)):
        for j, mode in enumerate(init_modes):
            ss = np.random.SeedSequence(seed, spawn_key=(DEMO_KEY, i, j))
            run_seed = int(ss.generate_state(1, np.uint64)[0] >> np.uint64(1))
            obs, acts, rews = demo_episode(with_init(problem, mode), conf, run_seed,
                                           population, budget, eta, delta)
            key = f"{name}/{mode}"
            scaler.reset(key)
            r = scaler.scale(key, rews)
            ret = np.zeros_like(r)
            acc = 0.0
            for t in range(len(r) - 1, -1, -1):
                acc = r[t] + gamma * acc
                ret[t] = acc
            for t in range(0, len(obs), stride):
                obs_all.append(obs[t])
                acts_all.append(acts[t])
                rets_all.append(ret[t])
                keys.append(key)
            if progress is not None:
                progress(i * len(init_modes) + j + 1, total)
    return Demos(obs_all, np.stack(acts_all), np.asarray(rets_all, dtype=np.float32), keys)


__all__ = ["DEMO_KEY", "Demos", "RewardScaler", "collect_demos", "demo_episode"]

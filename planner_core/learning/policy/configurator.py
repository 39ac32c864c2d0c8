"""`PolicyConfigurator`: the trained meta-level policy as a DE configurator ("lamde").

Each generation it builds the env's observation of the DE state
(:func:`planner_core.learning.env.observe`),
runs the numpy network (:mod:`planner_core.learning.policy.network`) and returns one (mutation,
crossover,
F, Cr) per individual. A network with context (``NetConfig.context``, issue 34) also keeps the
env's context memory (per-arm success, stagnation) through ``init``/``update``.

Determinism: by default the action is *sampled* from the policy's distributions with the
generator the DE core hands to ``configure`` (generation g's stream of the run's seed, after the
words ask uses), in the fixed order of
:func:`~planner_core.learning.policy.network.sample_actions`; so the
same seed gives the same plan, and the policy runs as it was trained (stochastic). With
``mode=True`` it takes the most likely action instead (argmax operators, Beta modes), which uses
no randomness at all.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from planner_core.learning.env import (
    DEFAULT_ETA,
    FeatureMemory,
    initial_features,
    next_features,
    observe,
)
from planner_core.learning.policy.checkpoint import DEFAULT_CHECKPOINT, load
from planner_core.learning.policy.network import NetConfig, forward, mode_actions, sample_actions
from planner_core.search.de.core import Config, DEState, Outcome


@dataclass(frozen=True, eq=False)
class PolicyConfigurator:
    """Configurator driven by a policy checkpoint (shipped name or folder path).

    ``mode``: take each distribution's mode instead of sampling (see module doc).
    ``eta``: the exponent scale of the observation (must match training; stored in the
    checkpoint's training metadata when present).
    """

    checkpoint: str | os.PathLike[str] = DEFAULT_CHECKPOINT
    mode: bool = False
    params: dict[str, np.ndarray] = field(default=None, repr=False)  # type: ignore[assignment]
    net: NetConfig = field(default=None, repr=False)  # type: ignore[assignment]
    eta: float = DEFAULT_ETA

    def __post_init__(self) -> None:
        if self.params is None or self.net is None:
            params, net, config = load(self.checkpoint)
            object.__setattr__(self, "params", {k: v.astype(np.float32) for k, v in
                                                params.items()})
            object.__setattr__(self, "net", net)
            eta = config.get("training", {}).get("eta")
            if eta is not None:
                object.__setattr__(self, "eta", float(eta))

    @property
    def name(self) -> str:
        """The name a plan's record gives this configurator (`PlanConfig.configurator_name`):
        ``lamde`` for the shipped checkpoint, else ``lamde:CHECKPOINT`` (the folder or shipped
        name it was given), with ``:mode`` when it takes the modes.

        Returns:
            The name.
        """
        ck = str(self.checkpoint)
        base = "lamde" if ck == DEFAULT_CHECKPOINT else f"lamde:{ck}"
        return base + (":mode" if self.mode else "")

    def init(self, state: DEState) -> FeatureMemory | None:
        """The run's context memory when the network reads it (``net.context``), else None.

        Args:
            state: the DE state at the run's start (unused).

        Returns:
            :func:`planner_core.learning.env.initial_features`, or None.
        """
        return initial_features() if self.net.context else None

    def configure(self, state: DEState, rng: np.random.Generator) -> Config:
        """One (mutation, crossover, F, Cr) per individual for this generation: the network on the
        env's observation of `state`, sampled (or, with ``mode``, its modes; module doc).

        Args:
            state: the DE state (population, f, phi, generation, context memory).
            rng: generation g's generator from the DE core (unused with ``mode``).

        Returns:
            The :class:`Config`, (N,) entries each.
        """
        out = forward(self.params, self.net, observe(state, self.eta))
        mut, cx, F, Cr = mode_actions(out) if self.mode else sample_actions(out, rng)
        return Config(mut, cx, F, Cr)

    def update(self, memory: Any, outcome: Outcome) -> FeatureMemory | None:
        """The next context memory (:func:`planner_core.learning.env.next_features`), or None
        for a network without context.

        Args:
            memory: the memory `init` or the last update returned.
            outcome: the generation's outcome.

        Returns:
            The next `FeatureMemory`, or None when `memory` is not one.
        """
        if not isinstance(memory, FeatureMemory):
            return None
        return next_features(memory, outcome)

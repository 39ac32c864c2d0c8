"""The learned meta-level (paper Sec. 4.2): policy network, numpy inference, the "lamde"
configurator and checkpoint I/O. Training (torch) lives in :mod:`planner_core.learning.policy.ppo`
and is
not imported here, so planning never needs torch."""

from planner_core.learning.policy.checkpoint import (
    DEFAULT_CHECKPOINT,
    CheckpointError,
    load,
    resolve,
    save,
)
from planner_core.learning.policy.configurator import PolicyConfigurator
from planner_core.learning.policy.network import (
    NetConfig,
    PolicyOutput,
    forward,
    init_params,
    log_prob,
    mode_actions,
    param_count,
    sample_actions,
)

__all__ = [
    "DEFAULT_CHECKPOINT",
    "CheckpointError",
    "NetConfig",
    "PolicyConfigurator",
    "PolicyOutput",
    "forward",
    "init_params",
    "load",
    "log_prob",
    "mode_actions",
    "param_count",
    "resolve",
    "sample_actions",
    "save",
]

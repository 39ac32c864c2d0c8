"""`Plan`: the immutable result of planning, read by every later stage (items, files, sim)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from planner_core.defaults import CONFIGURATOR
from planner_core.model.formulas import penalised_score
from planner_core.pipeline.evaluator import StageRecord

__all__ = ["Plan", "PLAN_FORMAT_VERSION"]

PLAN_FORMAT_VERSION = 1


def _frozen(a: Any, shape: tuple[int, ...] | None = None) -> np.ndarray:
    arr = np.array(a, dtype=float)
    if shape is not None:
        arr = arr.reshape(shape)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class Plan:
    """Hover points (I x 2, local metres) with hover times (s), their scores and provenance.

    `breakdown` is `Problem.breakdown` of the final solution; `history` holds the incumbent
    after each improvement (`evaluations`, `best_f`, `best_phi` arrays); `polish` records f
    and phi before and after the hover-time LP (None when the polish did not run); `stages`
    has one `planner_core.pipeline.StageRecord` per stage that ran (evaluations, seconds, f
    and phi before and after); `config` the run's `PlanConfig` as a dict; `stopped` is
    "time limit" when the clock ended the run, else ""; `timings` (s): setup (reading the map
    and inflating its obstacles by the clearance), compile (the kernels, once per process),
    planning (the pipeline), evaluation (inside it), total (all of these, = `wall_time`).
    `wall_time` (s) is the whole `plan()` call, compile included: compare plans by
    `timings["planning"]`, which a cold kernel cache does not stretch.
    """

    map_name: str
    hover_points: np.ndarray
    hover_times: np.ndarray
    f: float
    phi: float
    feasible: bool
    breakdown: dict[str, Any]
    evaluations: int
    wall_time: float
    history: dict[str, np.ndarray]
    seed: int
    configurator: str = CONFIGURATOR
    variable_length: bool = True
    polish: dict[str, Any] | None = None
    timings: dict[str, float] = field(default_factory=dict)
    stages: tuple[StageRecord, ...] = ()
    config: dict[str, Any] = field(default_factory=dict)
    stopped: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "stages", tuple(self.stages))
        object.__setattr__(self, "hover_points", _frozen(self.hover_points, (-1, 2)))
        object.__setattr__(self, "hover_times", _frozen(self.hover_times, (-1,)))
        object.__setattr__(
            self, "history", {k: _frozen(v) for k, v in dict(self.history).items()}
        )
        if len(self.hover_points) != len(self.hover_times):
            raise ValueError("hover_points and hover_times differ in length")

    @property
    def n_hover(self) -> int:
        """The number of points, hover points and 0 s corners together.

        Returns:
            I, the length of `hover_times`.
        """
        return len(self.hover_times)

    @property
    def score(self) -> float:
        """f + 10 * phi (paper Sec. 5.2; `planner_core.model.formulas.penalised_score`).

        Returns:
            The penalised score, s (f in s, phi weighted by 10).
        """
        return float(penalised_score(self.f, self.phi))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready data; `Plan.from_dict(plan.to_dict())` gives an equal plan.

        Returns:
            Every field by name (arrays as lists, `stages` as their dicts), plus
            `format_version` (`PLAN_FORMAT_VERSION`).
        """
        return {
            "format_version": PLAN_FORMAT_VERSION,
            "map_name": self.map_name,
            "hover_points": self.hover_points.tolist(),
            "hover_times": self.hover_times.tolist(),
            "f": self.f,
            "phi": self.phi,
            "feasible": self.feasible,
            "breakdown": self.breakdown,
            "evaluations": self.evaluations,
            "wall_time": self.wall_time,
            "history": {k: v.tolist() for k, v in self.history.items()},
            "seed": self.seed,
            "configurator": self.configurator,
            "variable_length": self.variable_length,
            "polish": self.polish,
            "timings": dict(self.timings),
            "stages": [s.to_dict() for s in self.stages],
            "config": dict(self.config),
            "stopped": self.stopped,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Plan:
        """Inverse of `to_dict`.

        Args:
            d: a `to_dict` dict (e.g. read from JSON); `format_version`, `history`,
                `configurator`, `variable_length`, `polish`, `timings`, `stages`, `config` and
                `stopped` may be absent (their defaults); a stage's None reads back as inf.

        Returns:
            The plan.

        Raises:
            ValueError: an unsupported `format_version`, or hover points and hover times of
                different lengths.
            KeyError: a required field is missing.
        """
        version = d.get("format_version", PLAN_FORMAT_VERSION)
        if version != PLAN_FORMAT_VERSION:
            raise ValueError(f"format_version: unsupported plan format {version}")
        return cls(
            map_name=d["map_name"],
            hover_points=np.array(d["hover_points"], dtype=float).reshape(-1, 2),
            hover_times=d["hover_times"],
            f=float(d["f"]),
            phi=float(d["phi"]),
            feasible=bool(d["feasible"]),
            breakdown=d["breakdown"],
            evaluations=int(d["evaluations"]),
            wall_time=float(d["wall_time"]),
            history=d.get("history", {}),
            seed=int(d["seed"]),
            configurator=d.get("configurator", CONFIGURATOR),
            variable_length=bool(d.get("variable_length", True)),
            polish=d.get("polish"),
            timings=d.get("timings", {}),
            stages=tuple(_stage(s) for s in d.get("stages", [])),
            config=d.get("config", {}),
            stopped=d.get("stopped", ""),
        )

    def same_as(self, other: Plan) -> bool:
        """Bit-for-bit equality of the decision content (points, times, f, phi).

        Args:
            other: the plan to compare with.

        Returns:
            True when hover points, hover times, f and phi are exactly equal.
        """
        return (
            np.array_equal(self.hover_points, other.hover_points)
            and np.array_equal(self.hover_times, other.hover_times)
            and self.f == other.f
            and self.phi == other.phi
        )


def _stage(d: dict[str, Any]) -> StageRecord:
    """A `StageRecord` from its `to_dict` (None read back as inf: no incumbent yet)."""
    return StageRecord(**{k: float("inf") if v is None else v for k, v in d.items()})

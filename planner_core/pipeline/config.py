"""`PlanConfig`: every knob of a plan in one frozen value, checked once.

Defaults and valid ranges come from the defaults table (`planner_core.defaults`); a config that
is built is valid, so no stage checks its options again (cf. pycma's options: a run keeps the
options it ran with, `Plan.config`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from planner_core import defaults as D

__all__ = ["PlanConfig"]


@dataclass(frozen=True)
class PlanConfig:
    """Every setting of a planning run (defaults table names; `planner_core.defaults`).

    Args:
        seed: random seed, >= 0 (same seed and budget, same plan).
        budget: evaluations in all, from the population to `MAX_BUDGET`
            (`planner_core.defaults.check_budget`).
        population: the DE's population N, >= `MIN_POPULATION`.
        configurator: a registry name (`CONFIGURATORS`) or a configurator object.
        init: start mode, "seeded" or "uniform" (`INIT_MODES`).
        memetic: "auto", "on" or "off": the DE's memetic step on the elite.
        starts: constructive plans put into the DE's initial population, >= 0.
        start_candidates: constructive plans built and scored, >= 0.
        descents: best plans of each kind descended before the DE, >= 0.
        descent_trials, restructure_trials, kick_trials, other_trials: evaluations of one
            descent, of the structural search, of the kicks and of a second structure, >= 0
            (descent_trials 0: no descent and no finish, which starts with one; the defaults
            table says where the evaluations go).
        de_share: share of the budget the DE gets (at least its population), in [0, 1].
        descent: False turns off every descent and the final stage (`--no-descent`).
        polish: False turns off the LP polish and every stage after it (`--no-polish`).
        variable_length: False: every one of the I_max points is flown (LAMDE-F).
        time_limit: seconds after which the improving stages stop (None: no limit).
        order: the constructive plans' visiting order (None: the planner's own open path;
            the `planner-eng-start` benchmark entry passes OR-Tools').

    Raises:
        ValueError: one line naming the first bad field (`"budget: must be an integer >=
            population (100), got 50"`).
    """

    seed: int = D.SEED
    budget: int = D.BUDGET
    population: int = D.POPULATION
    configurator: str | Any = D.CONFIGURATOR
    init: str = D.INIT
    memetic: str = D.MEMETIC
    starts: int = D.STARTS
    start_candidates: int = D.START_CANDIDATES
    descents: int = D.DESCENTS
    descent_trials: int = D.DESCENT_TRIALS
    restructure_trials: int = D.RESTRUCTURE_TRIALS
    kick_trials: int = D.KICK_TRIALS
    other_trials: int = D.OTHER_TRIALS
    de_share: float = D.DE_SHARE
    descent: bool = True
    polish: bool = True
    variable_length: bool = True
    time_limit: float | None = None
    order: Callable[..., Any] | None = None

    def __post_init__(self) -> None:
        D.check_run_args(population=self.population, budget=self.budget,
                         configurator=self.configurator, init=self.init, memetic=self.memetic,
                         starts=self.starts, start_candidates=self.start_candidates)
        for name in ("seed", "descents", "descent_trials", "restructure_trials", "kick_trials",
                     "other_trials", "de_share"):
            D.check(name, getattr(self, name))
        if self.time_limit is not None:
            D.check("time_limit", self.time_limit)

    def replace(self, **changes: Any) -> PlanConfig:
        """A copy with `changes` (checked again).

        Args:
            **changes: field name -> new value.

        Returns:
            The new `PlanConfig`.

        Raises:
            ValueError: a changed field out of its range (as the constructor).
            TypeError: a name that is no field.
        """
        return dataclasses.replace(self, **changes)

    @property
    def configurator_name(self) -> str:
        """The configurator's registry name; for an object its own ``name`` when it has one
        (`PolicyConfigurator`: ``lamde:CHECKPOINT``), else its class name.

        Returns:
            The name.
        """
        c = self.configurator
        if isinstance(c, str):
            return c
        name = getattr(c, "name", None)
        return name if isinstance(name, str) else type(c).__name__

    @property
    def final_trials(self) -> int:
        """Evaluations of one finish of a plan: its descent, the structural search, the removal
        moves and the kicks (0 with the descent off).

        Returns:
            descent_trials + restructure_trials + kick_trials, or 0 with `descent` False.
        """
        if not self.descent:
            return 0
        return self.descent_trials + self.restructure_trials + self.kick_trials

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready settings (a configurator object and `order` by name).

        Returns:
            {field: value}; `configurator` its `configurator_name`, `order` None or the
            callable's `__name__` (its class name without one).
        """
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["configurator"] = self.configurator_name
        out["order"] = None if self.order is None else getattr(self.order, "__name__",
                                                                   type(self.order).__name__)
        return out

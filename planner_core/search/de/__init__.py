"""Differential Evolution with per-individual configuration (the paper's low-level optimiser)."""

from planner_core.model.formulas import deb_best, deb_better, deb_order
from planner_core.search.de.configurators import (
    AdaptiveConfigurator,
    FixedConfigurator,
    RandomConfigurator,
    make_configurator,
)
from planner_core.search.de.core import (
    ask,
    ask_words,
    init,
    outcome,
    step,
    tell,
    to_problem,
    to_unit,
)
from planner_core.search.de.loop import run
from planner_core.search.de.operators import CROSSOVERS, MUTATIONS
from planner_core.search.de.rng import generation_rng
from planner_core.search.de.types import (
    BoxProblem,
    Config,
    Configurator,
    DEState,
    History,
    Outcome,
    Progress,
    Result,
    max_generations,
)

__all__ = [
    "CROSSOVERS",
    "MUTATIONS",
    "AdaptiveConfigurator",
    "BoxProblem",
    "Config",
    "Configurator",
    "DEState",
    "FixedConfigurator",
    "History",
    "Outcome",
    "Progress",
    "RandomConfigurator",
    "Result",
    "ask",
    "ask_words",
    "deb_best",
    "deb_better",
    "deb_order",
    "generation_rng",
    "init",
    "make_configurator",
    "max_generations",
    "outcome",
    "run",
    "step",
    "tell",
    "to_problem",
    "to_unit",
]

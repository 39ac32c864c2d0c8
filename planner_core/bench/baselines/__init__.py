"""Optimisers compared by the benchmark, behind one interface and one budget accounting.

Each optimiser lives in its own module with ``optimise(problem, budget, seed) -> OptimiseResult``
(x, f, phi, evaluations, history). The registry below maps names to those functions (imported
lazily, so listing names never imports cma or scipy). `optimise(name, problem, budget, seed)`
builds the problem in the variant's encoding (variable- or fixed-length), wraps it in a
`Evaluator` so nothing can be evaluated past the budget, and checks the count.

Our DE variants report the raw DE result (no cvxpy hover polish), so the comparison is on the
optimiser alone; `lamde_mission.api.plan` adds the polish for users.
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from planner_core.defaults import (
    CONFIGURATOR,
    CONFIGURATORS,
    POPULATION,
    SCORE_FACTOR,
    START_CANDIDATES,
    check,
    check_budget,
)
from planner_core.pipeline.evaluator import (
    BudgetExceeded,
    Criterion,
    Evaluator,
    Trace,
    as_evaluator,
)
from planner_core.search.init_modes import INIT_MODES, UniformStart, with_init

__all__ = [
    "BudgetExceeded",
    "Evaluator",
    "Criterion",
    "INIT_MODES",
    "OptimiseResult",
    "OptimiserSpec",
    "REGISTRY",
    "Trace",
    "UniformStart",
    "as_evaluator",
    "get",
    "missing_extras",
    "names",
    "optimise",
    "policy_spec",
    "problem_for",
    "with_start",
]


class OptimiseResult(NamedTuple):
    """Best solution found (problem space), its f and phi, evaluations spent, convergence trace;
    `last_feasible_rate`: the fraction of the last population with phi = 0 (population-based
    optimisers that report it; None otherwise; the I_max study, paper Fig. 4)."""

    x: np.ndarray
    f: float
    phi: float
    evaluations: int
    history: Trace
    last_feasible_rate: float | None = None


#: start modes of a benchmark run, the wrapper and the chooser: one place,
#: planner_core.search.init_modes
with_start = with_init

@dataclass(frozen=True)
class OptimiserSpec:
    """A registry entry: where the function lives, fixed keyword arguments, the encoding used."""

    name: str
    target: str  # "module:function"
    description: str
    kwargs: dict[str, Any] = field(default_factory=dict)
    variable_length: bool | None = True  # None: whatever the given problem uses
    spends_budget: bool = True  # False: may stop early (seed-lp; the planner's descents)
    #: evaluations charged before the run (the landscape-aware module's probes of the task,
    #: which the paper counts in LAMDE's budget): the optimiser gets budget - probe_evaluations
    probe_evaluations: int = 0
    #: True: builds its plans without any start population, so it is the same in both start
    #: modes (`--init seeded|uniform`), and its seed may not change the answer on a small map
    constructive: bool = False
    #: modules it imports beyond the package's own dependencies, and the pip extra of
    #: pyproject.toml that installs them (`missing_extras`)
    requires: tuple[str, ...] = ()
    extra: str | None = None

    def missing(self) -> list[str]:
        """The modules of `requires` not installed here (found without importing them).

        Returns:
            Their names, in `requires` order; empty when it can run.
        """
        import importlib.util

        return [m for m in self.requires if importlib.util.find_spec(m) is None]

    def function(self) -> Any:
        """The optimiser's function, imported from `target` ("module:function") now.

        Returns:
            The callable `optimise(problem, budget, seed, **kwargs) -> OptimiseResult`.

        Raises:
            ImportError: its module (or a library it needs: cma, scipy, pymoo, ortools) is not
                installed.
            AttributeError: the module has no such function.
        """
        module, func = self.target.split(":")
        return getattr(importlib.import_module(module), func)


def _de(configurator: str, variable_length: bool) -> OptimiserSpec:
    suffix = "" if variable_length else "-fixedlen"
    enc = "variable-length" if variable_length else "fixed-length (all I_max points active)"
    return OptimiserSpec(
        name=f"de-{configurator}{suffix}",
        target="planner_core.bench.baselines.de:optimise",
        description=f"our DE, {configurator} configurator, {enc}, population {POPULATION}, "
        "no polish",
        kwargs={"configurator": configurator},
        variable_length=variable_length,
    )


#: every optimiser the benchmark knows, in the report's column order
REGISTRY: dict[str, OptimiserSpec] = {
    s.name: s
    for s in (
        *(_de(name, fixed) for name in CONFIGURATORS for fixed in (True, False)),
        OptimiserSpec(
            "cmaes",
            "planner_core.bench.baselines.cmaes:optimise",
            f"pycma CMA-ES on f + {SCORE_FACTOR:g} phi in the unit box (BoundTransform), "
            "sigma0 0.3, default popsize, restarts within the budget",
        ),
        OptimiserSpec(
            "planner",
            "planner_core.bench.baselines.de:planner",
            "what `plan` does: the declared pipeline (planner_core.pipeline: constructive "
            f"plans, their descents, our DE ({CONFIGURATOR} configurator, population "
            f"{POPULATION}, de_share of the budget; from a uniform start with the memetic "
            "step), the polish LP, the final stage on the incumbent and a second structure, "
            "then improving rounds, or the repair while infeasible); budget counted exactly",
            # the improving rounds stop when they find nothing to spend on (`plan` too:
            # evaluations <= budget)
            spends_budget=False,
        ),
        OptimiserSpec(
            "planner-lamde-s",
            "planner_core.bench.baselines.de:planner",
            "the planner with `--scheduler lamde-s`: the learned selector picks the DE's "
            "share of the budget from the map (more evaluations for the improving rounds, "
            "within 1.5x the default's CPU) and the improving stage's schedule from the run "
            "(docs/scheduler.md)",
            kwargs={"scheduler": "lamde-s"},
            spends_budget=False,
        ),
        OptimiserSpec(
            "planner-no-descent",
            "planner_core.bench.baselines.de:planner",
            "the planner without the hover-point descent and the stages after the polish "
            "(`plan(descent=False)`, `plan --no-descent`): constructive plans, the DE on the "
            "rest, the polish LP",
            kwargs={"descent": False},
        ),
        OptimiserSpec(
            "planner-no-starts",
            "planner_core.bench.baselines.de:planner",
            "the planner without constructive plans and descents (`plan --starts 0 "
            "--no-descent`; the planner before issue 14): our DE on budget - 16, then the "
            "polish LP",
            kwargs={"starts": 0, "descent": False},
        ),
        OptimiserSpec(
            "planner-memetic",
            "planner_core.bench.baselines.de:planner",
            "the planner-no-starts pipeline with the memetic step on the elite every 10 "
            "generations in both start modes (2-opt order, LP hover times, removals, pulls; "
            "planner_core.search.refine), then the polish LP",
            kwargs={"starts": 0, "descent": False, "memetic": "on"},
        ),
        OptimiserSpec(
            "seed-lp",
            "planner_core.bench.baselines.seed_lp:optimise",
            "best seed + LP, no search: the Deb-best of our DE's seeded initial population, "
            "hover times re-solved by the polish LP (the floor a search must beat)",
            spends_budget=False,
        ),
        OptimiserSpec(
            "cmaes-seeded-lp",
            "planner_core.bench.baselines.cmaes:optimise",
            "pycma CMA-ES started at the best seed (sigma0 0.002 in the unit box, restarts from "
            "the best so far), then the polish LP",
            kwargs={"seeded": True},
        ),
        OptimiserSpec(
            "engineering",
            "planner_core.bench.baselines.engineering:optimise",
            "the plain engineering pipeline, no DE: hover sites by greedy set cover / a k-means "
            "sweep, visiting order by OR-Tools' routing solver, sites slid to clear their legs, "
            "blocked legs routed through the visibility graph, the polish LP; the Deb-best of "
            "its candidates (one evaluation each); the same in both start modes",
            spends_budget=False,
            constructive=True,
            requires=("ortools",),
            extra="baselines",
        ),
        OptimiserSpec(
            "engineering-own-order",
            "planner_core.bench.baselines.engineering:optimise",
            "the engineering pipeline with the planner's own visiting order (open path: "
            "nearest neighbour and cheapest insertion, 2-opt, Or-opt) instead of OR-Tools'",
            kwargs={"order": "own"},
            spends_budget=False,
            constructive=True,
        ),
        OptimiserSpec(
            "planner-eng-start",
            "planner_core.bench.baselines.eng_start:optimise",
            "the planner started from the `engineering` entry's plans: every constructive "
            "candidate, ordered by OR-Tools, scored, the 10 best in place of the start "
            "population's last 10 rows (`planner` instead scores its first "
            f"{START_CANDIDATES}, ordered by its own open path)",
            spends_budget=False,  # the planner's improving rounds may stop early
            requires=("ortools",),
            extra="baselines",
        ),
        OptimiserSpec(
            "pymoo-ga",
            "planner_core.bench.baselines.pymoo_ga:optimise",
            f"pymoo GA (population {POPULATION}, SBX, polynomial mutation, feasibility-first "
            "tournament and survival on G = phi <= 0) from the DE's start population of the "
            "run's start mode, then the polish LP",
            requires=("pymoo",),
            extra="baselines",
        ),
        OptimiserSpec(
            "scipy-de",
            "planner_core.bench.baselines.scipy_de:optimise",
            f"scipy.optimize.differential_evolution on f + {SCORE_FACTOR:g} phi (best1bin, "
            f"F in (0.5, 1), CR 0.7, deferred updating), population {POPULATION}, restarts "
            "within the budget",
        ),
        OptimiserSpec(
            "lsrtde",
            "planner_core.bench.baselines.lsrtde:optimise",
            "L-SRTDE (Stanovov & Semenkin 2024, CEC 2024 winner): success-rate-based F, "
            "linear population reduction, Deb's rule for constraints",
        ),
        OptimiserSpec(
            "cmocso",
            "planner_core.bench.baselines.cmocso:optimise",
            "CMOCSO (Ming et al. 2023, IEEE TEVC): competitive swarm (losers learn from "
            "winners, epsilon-constrained SPEA2 fitness) and cooperative swarm (SBX, "
            f"constraints ignored), population {POPULATION} each; objective f, constraint phi "
            "(no penalty)",
        ),
        OptimiserSpec(
            "random-search",
            "planner_core.bench.baselines.random_search:optimise",
            "uniform random sampling, best under Deb's rule (the floor)",
        ),
    )
}


def policy_spec(name: str, checkpoint: str, *, variable_length: bool = True,
                probe_evaluations: int = 0, description: str = "") -> OptimiserSpec:
    """A benchmark entry `name` for our DE driven by the policy checkpoint folder `checkpoint`
    (the ablation variants of paper Sec. 5.3, `benchmarks/ablations.py`): population
    POPULATION, no polish, the given encoding. The entry is not in REGISTRY: pass it to
    `optimise(..., spec=)` or `run_bench(..., extra=)`.

    Args:
        name: the entry's name.
        checkpoint: the policy checkpoint folder (configurator "lamde").
        variable_length: the encoding: variable-length (True) or fixed-length.
        probe_evaluations: evaluations charged to its budget before the run (see
            OptimiserSpec), >= 0.
        description: the report's description (default: one built from the arguments).

    Returns:
        The `OptimiserSpec`.

    Raises:
        ValueError: a negative probe count.
    """
    if probe_evaluations < 0:
        raise ValueError(f"probe_evaluations: must be >= 0, got {probe_evaluations}")
    enc = "variable-length" if variable_length else "fixed-length (all I_max points active)"
    return OptimiserSpec(
        name=name,
        target="planner_core.bench.baselines.de:optimise",
        description=description or f"our DE driven by the policy {checkpoint}, {enc}, "
        f"population {POPULATION}, no polish"
        + (f", {probe_evaluations} probe evaluations charged" if probe_evaluations else ""),
        kwargs={"configurator": "lamde", "policy": str(checkpoint)},
        variable_length=variable_length,
        probe_evaluations=int(probe_evaluations),
    )


def missing_extras(names: Sequence[str], extra: Sequence[OptimiserSpec] = ()) -> str | None:
    """Why some of the optimisers `names` cannot run here, in one line, or None: each whose
    `requires` are not all installed, with the modules it needs, then the pip extra that
    installs them ("engineering needs ortools, pymoo-ga needs pymoo, not installed: pip
    install 'lamde-mission[baselines]'"), so a benchmark is refused (or, by default, runs
    without them) before it starts instead of failing run by run.

    Args:
        names: optimiser names (the registry's or `extra`'s; unknown names are skipped).
        extra: entries outside the registry (`policy_spec`).

    Returns:
        The line, or None when every one can run.
    """
    specs = {**REGISTRY, **{e.name: e for e in extra}}
    lacking: dict[str, list[str]] = {}  # extra -> "name needs modules", in names' order
    for name in dict.fromkeys(names):
        spec = specs.get(name)
        gone = spec.missing() if spec is not None else []
        if gone:
            lacking.setdefault(spec.extra or "", []).append(f"{name} needs {', '.join(gone)}")
    if not lacking:
        return None
    return "; ".join(
        f"{', '.join(who)}, not installed"
        + (f": pip install 'lamde-mission[{key}]'" if key else "")
        for key, who in lacking.items()
    )


def names() -> list[str]:
    """Registered optimiser names, in the report's column order.

    Returns:
        The names of `REGISTRY`.
    """
    return list(REGISTRY)


def get(name: str) -> OptimiserSpec:
    """The registry entry for `name`.

    Args:
        name: a registered optimiser name.

    Returns:
        Its `OptimiserSpec`.

    Raises:
        KeyError: an unknown name (the message names the valid choices).
    """
    try:
        return REGISTRY[name]
    except KeyError:
        raise KeyError(f"unknown optimiser '{name}'; choose from {', '.join(REGISTRY)}") from None


def problem_for(name: str, problem: Any, spec: OptimiserSpec | None = None) -> Any:
    """The problem in the encoding optimiser `name` (or `spec`, an entry outside the registry)
    uses (a new fixed-length Problem if needed).

    Args:
        name: the optimiser's registry name (used when `spec` is None).
        problem: the UAV problem (`planner_core.model.problem.Problem`).
        spec: an entry outside the registry, or None.

    Returns:
        `problem` itself when its encoding fits (or the entry takes any), else a new `Problem`
        on the same map with the entry's `variable_length`.

    Raises:
        KeyError: `spec` is None and `name` is not registered.
    """
    spec = spec or get(name)
    want = spec.variable_length
    if want is None or getattr(problem, "variable_length", want) == want:
        return problem
    from planner_core.model.problem import Problem

    return Problem(problem.map, variable_length=want)


def optimise(name: str, problem: Any, budget: int, seed: int,
             init: str = "seeded", spec: OptimiserSpec | None = None) -> OptimiseResult:
    """Run optimiser `name` on `problem` with at most `budget` evaluations; same seed, same result.

    The returned x is in the encoding of `problem_for(name, problem)` (use that problem to
    decode). An entry's `probe_evaluations` are charged first: the optimiser gets the rest of
    the budget, and the result's evaluation count and trace include the probes (so the trace
    starts at probes + the first population).

    Args:
        name: the optimiser's name (registered, or `spec`'s).
        problem: the UAV problem.
        budget: evaluations at most, counted by an `Evaluator`.
        seed: the run's seed.
        init: "seeded" (the problem's `initial_population` hook, when it has one) or "uniform"
            (the hook hidden: uniform starts in the box).
        spec: an entry outside the registry (`policy_spec`) to run under `name`.

    Returns:
        The `OptimiseResult`.

    Raises:
        KeyError: an unknown name without `spec`.
        ValueError: a budget that is not an integer in [1, MAX_BUDGET] or does not exceed
            the probe evaluations, a seed that is not an integer >= 0 (each named), an
            unknown start mode, or a budget the optimiser refuses.
        RuntimeError: the optimiser reported another evaluation count than the one counted.
    """
    check_budget(budget, 1, least_name=None)  # an integer: 200.5 ran as 200
    check("seed", seed)  # a negative seed: numpy's error named no argument
    spec = spec or get(name)
    probe = int(spec.probe_evaluations)
    if probe >= int(budget):
        raise ValueError(f"{name}: budget {budget} does not exceed its {probe} probe evaluations")
    own = int(budget) - probe
    budgeted = Evaluator(with_start(problem_for(name, problem, spec), init), own)
    res = spec.function()(budgeted, own, int(seed), **spec.kwargs)
    if res.evaluations != budgeted.count or budgeted.count > own:
        raise RuntimeError(
            f"{name}: reported {res.evaluations} evaluations, counted {budgeted.count} "
            f"(budget {own})"
        )
    if probe:
        h = res.history
        res = res._replace(evaluations=res.evaluations + probe,
                           history=Trace(h.evaluations + probe, h.best_f, h.best_phi))
    return res


"""Every default of the planner in one table: name, value, one-line meaning, valid range.

In the spirit of pycma's options (``cma.CMAOptions``): one entry per setting, read by the CLI,
the Python API, the optimisation env, the benchmark and the map loader, so a value is changed in
one place and every ``--help`` text, error message and README table follows. This module
imports nothing but the standard library (the CLI reads it while building ``--help`` without
loading numpy or numba).

Read a value with ``DEFAULTS["population"].value`` or the module constants (``POPULATION``,
``BUDGET``, ...); check a user's value with :func:`check`, which raises a ``ValueError`` whose
message starts with the entry's name (``"population: must be an integer >= 6, got 5"``).
:func:`render_markdown` renders the table (the README's "Defaults" section is generated from it
and a test keeps the two equal).

Memory at the input limits (the limits themselves live in ``planner_core.textio.LIMITS``; each
bound is held by a slow test that runs ``check`` and ``plan`` in a child under ``ulimit -v``
4 GB, RLIMIT_AS, and asks for a peak RSS under 2 GB):

- ``LAMDE_MAX_SENSORS`` (1,000 sensors): within 4 GB of address space; peak RSS ~210 MiB for
  ``check``, ~710 MiB for ``plan`` at a small budget (tests/test_limits_memory.py, a 30 km
  uniform map from ``generate --layout uniform``), 684 MiB at the default budget on a 30 km
  uniform map of 1,000 sensors (207 s of CPU; docs/scaling.md, "A thousand sensors");
- ``LAMDE_MAX_OBSTACLES`` (5,000 circles, rectangles, zones and polygons): within 4 GB; peak RSS
  ~390 MiB for ``check``, ~715 MiB for ``plan`` (tests/test_limits_memory.py, 2,500 circles and
  2,500 rectangles on a 16 km grid); the plan's time, not its memory, is what grows (~140-150 s
  of CPU, most of it the visibility graph's clearance tests of every tangent pair against every
  obstacle);
- ``LAMDE_MAX_VERTICES`` (50,000 zone vertices; ``LAMDE_MAX_ZONE_VERTICES``, 5,000 per zone,
  lies within it): within 4 GB; peak RSS ~340 MiB for ``plan`` (tests/test_graph_memory.py:
  the graph's candidate pairs are built one block at a time) for convex zones; non-convex zones
  cost more (10 stars of 5,000 vertices on 10 km: ``check`` 70 s and 667 MB, most of it their
  inflation, ``plan`` 53-66 s and 711-738 MB; docs/maps.md);
- the file limits (``LAMDE_MAX_INPUT_BYTES``, 64 MiB; ``LAMDE_MAX_JSON_DEPTH``, 64) bound what
  is read before any of the above is built.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

__all__ = [
    "ACCESS_MODES",
    "BEST_KNOWN_BUDGET",
    "BEST_KNOWN_RUNS",
    "BUDGET",
    "CONFIGURATOR",
    "CONFIGURATORS",
    "DEFAULTS",
    "DELTA",
    "Default",
    "ETA",
    "GOALS",
    "INIT",
    "INIT_MODES",
    "MEMETIC",
    "MEMETIC_MODES",
    "L_VIO_TOL",
    "MAP_CHOICES",
    "MAP_DEFAULTS",
    "MAP_LISTS",
    "MAX_BUDGET",
    "MAX_DEPOTS",
    "MIN_POPULATION",
    "SHARE_MAX",
    "POPULATION",
    "RUNS",
    "SCORE_FACTOR",
    "SEED",
    "STARTS",
    "DESCENTS",
    "DE_SHARE",
    "DESCENT_TRIALS",
    "RESTRUCTURE_TRIALS",
    "KICK_TRIALS",
    "OTHER_TRIALS",
    "START_CANDIDATES",
    "SUITE_SEED",
    "TRAIN_DEFAULTS",
    "check",
    "check_budget",
    "check_run_args",
    "interval_text",
    "number_text",
    "obstacle_label",
    "render_markdown",
    "update_readme",
    "with_table",
]


@dataclass(frozen=True)
class Default:
    """One setting: its name, default value, a one-line meaning, and its valid range.

    ``valid`` is the range in words (shown in tables and error messages); ``ok`` is the same
    range as a predicate over a candidate value (None: any value of the default's type).
    """

    name: str
    value: Any
    meaning: str
    valid: str
    ok: Callable[[Any], bool] | None = None
    #: a map number's physical range (lo, hi, lo_open, hi_open), applied by planner_core.model.mapio
    bounds: tuple[float, float, bool, bool] | None = None
    #: why the range is what it is (shown in the map's JSON Schema and its error lines)
    why: str = ""
    #: (below the range, above it) where each side has its own reason (`why` is then both,
    #: joined by "; "): an error line gives the side the value broke (`why_for`)
    why_sides: tuple[str, str] | None = None

    def check(self, value: Any) -> Any:
        """Return ``value`` if it lies in the valid range, else raise ``ValueError`` naming
        the setting.

        Args:
            value: the candidate value (any type; ``ok`` None accepts anything).

        Returns:
            ``value`` unchanged.

        Raises:
            ValueError: ``ok(value)`` is false; the message is
                ``"<name>: must be <valid>, got <value!r>"``.
        """
        if self.ok is not None and not self.ok(value):
            raise ValueError(f"{self.name}: must be {self.valid}, got {value!r}")
        return value

    def why_for(self, above: bool) -> str:
        """The reason for the side of the range a value broke.

        Args:
            above: the value lies above the range (else below it).

        Returns:
            That side's reason where `why_sides` gives one, else `why`.
        """
        return self.why if self.why_sides is None else self.why_sides[int(bool(above))]


def _is_int(v: Any) -> bool:
    # bool is an int subclass but never a count; numpy integers expose __index__
    return not isinstance(v, bool) and hasattr(v, "__index__") and not isinstance(v, float)


def _int_at_least(lo: int) -> Callable[[Any], bool]:
    return lambda v: _is_int(v) and int(v) >= lo


def _share(v: Any) -> bool:
    return (not isinstance(v, bool) and isinstance(v, int | float) and math.isfinite(v)
            and 0 <= v <= 1)


def _positive_number(v: Any) -> bool:
    return (not isinstance(v, bool) and isinstance(v, int | float) and math.isfinite(v)
            and v > 0)


#: the DE's mutations draw up to five donors distinct from each other and from the target
#: (rand/2), so a population needs at least six members (``de.operators.N_DONORS + 1``)
MIN_POPULATION = 6
#: the largest population: a generation holds a few (N, d) arrays of d = 4 I_max + 4 (<= 804)
#: floats, ~65 MB each at 10,000, where a population of the budget's size (10^7) would ask for
#: tens of GB
MAX_POPULATION = 10_000
#: the most objective evaluations one run may be given (a run's `budget`, `plan --budget` and
#: `--sortie-budget`, `bench --budget`, `train --budget`; `check_budget`): 10 x `bench
#: --best-known`'s 1,000,000 a run, so that no number a user gives makes a run endless
MAX_BUDGET = 10_000_000
#: the most runs per optimiser and task of one benchmark (`bench --runs`, `run_bench`): the
#: paper's protocol is 30 (Sec. 5), `--best-known`'s 5; the job list and the records grow with
#: runs x tasks x optimisers
MAX_RUNS = 1_000
#: the most worker processes (local backend) or CPUs of a Ray instance started here that one
#: command may ask for (`--jobs`, `make_executor`): each worker is a Python process of ~100-200
#: MB, so a number far beyond any machine's cores would exhaust its memory before doing work
MAX_JOBS = 256
#: configurator names, the default first (the hand-made adaptive DE until a trained policy beats
#: it on unseen maps; "lamde" is the shipped learned policy, planner_core.learning.policy);
#: ``planner_core.search.de.configurators`` registers exactly these
CONFIGURATORS: tuple[str, ...] = ("adaptive", "fixed", "random", "lamde")
#: start modes of a run (planner_core.search.init_modes), the default first: the problem's seeded
#: starts
#: (the product's) or uniform in the box (the paper's protocol)
INIT_MODES: tuple[str, ...] = ("seeded", "uniform")
#: when the planner runs the memetic step on the elite (`planner_core.search.refine`)
MEMETIC_MODES: tuple[str, ...] = ("auto", "on", "off")

_RUN: tuple[Default, ...] = (
    Default("population", 100, "DE population size N (individuals per generation)",
            f"an integer in [{MIN_POPULATION}, {MAX_POPULATION}]",
            lambda v: _is_int(v) and MIN_POPULATION <= int(v) <= MAX_POPULATION),
    Default("budget", 10_000, "objective evaluations per run, the initial population included "
            "(paper Sec. 5.1)", f"an integer in [population, {MAX_BUDGET}]",  # check_budget's
            lambda v: _is_int(v) and MIN_POPULATION <= int(v) <= MAX_BUDGET),
    Default("min_population", MIN_POPULATION, "smallest population the mutations work with "
            "(five distinct donors + the target, for rand/2)", f"fixed at {MIN_POPULATION}",
            lambda v: v == MIN_POPULATION),
    Default("configurator", CONFIGURATORS[0], "how each generation's mutation, crossover, F and "
            "Cr are chosen per individual", "one of " + ", ".join(CONFIGURATORS),
            lambda v: v in CONFIGURATORS),
    Default("init", INIT_MODES[0], "start mode: the problem's sensor-aware starts (seeded) or "
            "uniform in the box (the paper's protocol)", "one of " + ", ".join(INIT_MODES),
            lambda v: v in INIT_MODES),
    Default("memetic", MEMETIC_MODES[0], "memetic step on the elite every 10 generations "
            "(2-opt, LP hover times, removals; an infeasible elite gets a point above each "
            "sensor no point serves and its blocked legs re-routed): auto = on from a uniform "
            "start, where the DE alone rarely reaches every sensor, off from the seeded start, "
            "where it measured no gain (docs/search.md)", "one of " + ", ".join(MEMETIC_MODES),
            lambda v: v in MEMETIC_MODES),
    Default("starts", 10, "constructive plans (`planner_core.search.construct`: greedy set covers "
            "and a k-means sweep of hover sites, an open-path order on obstacle-aware flight "
            "times, visibility-graph detours, LP hover times) put into the DE's initial "
            "population in place of its last rows, the Deb-best of the `start_candidates` "
            "scored; 0: none (docs/search.md)", "an integer >= 0 (at most the population is "
            "used)", _int_at_least(0)),
    Default("start_candidates", 64, "constructive plans built and scored (one evaluation "
            "each, counted in the budget) to pick the `starts` from, at most: the pipeline "
            "builds 20-51 on the suite maps, so all of them; 0: none",
            "an integer >= 0", _int_at_least(0)),
    Default("descents", 3, "best plans of each kind (constructive, seeder) improved by the "
            "hover-point descent with exact LP hover times (`planner_core.search.descent`) before "
            "the DE; 0: none before the DE (`plan(descent=False)`, `--no-descent` turn off "
            "this and every stage after the polish; docs/search.md)", "an integer >= 0",
            _int_at_least(0)),
    Default("descent_trials", 40, "evaluations one descent may spend at most (counted in the "
            "budget); 0: no descent, and so no finish either (`planner_core.search.final."
            "finish` starts with the descent and stops when it does not run): the start "
            "descents, the final stage and the other structure spend nothing, the improving "
            "stage's restarts finish nothing (a fresh one still scores its constructive plans), "
            "and the evaluations go to the improving stage (its kicks and structural search "
            "still run)", "an integer >= 0", _int_at_least(0)),
    Default("restructure_trials", 300, "evaluations the structural search on the final plan "
            "may spend (`planner_core.search.structure.restructure`: drop the detour corners, "
            "merge two "
            "hover points, or split one in two, each move descended in a race against the "
            "incumbent), then at most as many again for the removal moves (one hover point "
            "removed, the lightest first, a neighbour moved to clear the leg that joins its "
            "neighbours; `removal_moves`), taken from the kicks' share; with the descent on",
            "an integer >= 0",
            _int_at_least(0)),
    Default("kick_trials", 300, "evaluations of the final stage's kicks (its share is "
            "descent_trials + restructure_trials + kick_trials) on the incumbent after the "
            "structural search and the removal moves (`planner_core.search.structure.kicks`: "
            "one hover point moved by a normal step of 300 m standard deviation per axis, the "
            "plan descended in a race against the incumbent, kept when better; with the descent "
            "on); the same share is one round of the improving stage",
            "an integer >= 0", _int_at_least(0)),
    Default("other_trials", 320, "evaluations of the pipeline's `other structure` stage: the "
            "best plan of the pool (constructive, seeder, descended) with fewer (else more) "
            "hover points than the incumbent, finished the same way (descent, structural "
            "search, removal moves, kicks; `planner_core.search.final.finish`); it runs only "
            "when at least descent_trials are left for it; 0: none",
            "an integer >= 0", _int_at_least(0)),
    Default("de_share", 0.6, "share of the budget the DE gets, of the default budget at most "
            "(and at least its population; `planner_core.pipeline`): the rest and any budget "
            "beyond the default go to the constructive plans, the descents, the polish, the "
            "final stage and the improving rounds (kicks, structural search, restarts from "
            "other structures and fresh constructive plans; beyond the paper's sizes, rebuilt "
            "windows of hover points instead of the restarts), the stages that turn budget into "
            "a better plan (docs/architecture.md, 'Where the budget goes'); on maps with the "
            "large rounds (I_max above 20 and variable length, either radio.access) the "
            "default scheduler makes the default 0 beyond 160 sensors: the DE runs its "
            "population, one generation (`planner_core.pipeline.schedule.LARGE_DE_SHARE`; "
            "docs/scaling.md, 'One DE generation beyond 160 sensors'), and 0.2 up to 120 "
            "sensors (`MID_DE_SHARE`); from 121 to 160 it stays 0.6",
            "a number in [0, 1]", _share),
    Default("time_limit", None, "seconds after which the pipeline stops its improving stages "
            "and returns the best plan found (null: none; the kernel compile is not counted); "
            "a time limit trades determinism for a deadline", "null or a number > 0",
            lambda v: v is None or _positive_number(v)),
    Default("seed", 0, "random seed of a planning run (same seed, same plan)", "an integer >= 0",
            _int_at_least(0)),
    Default("score_factor", 10.0, "penalised score f + 10 * phi that ranks optimisers "
            "(paper Sec. 5.2)", "a number > 0", _positive_number),
    Default("suite_seed", 2025, "seed the committed 16-map benchmark suite was generated with",
            "an integer >= 0", _int_at_least(0)),
    Default("runs", 25, "benchmark runs per optimiser and task (paper Sec. 5.1)",
            "an integer >= 1", _int_at_least(1)),
    Default("best_known_budget", 1_000_000, "evaluations per run when searching best-known "
            "solutions (`bench --best-known`: 100 x the paper's budget)", "an integer >= 1",
            _int_at_least(1)),
    Default("best_known_runs", 5, "runs per optimiser and task of `bench --best-known`",
            "an integer >= 1", _int_at_least(1)),
    Default("eta", 10.0, "scale of the env's mantissa-exponent encoding: exponent b is "
            "observed as b / eta (paper Sec. 4.2)", "a number > 0", _positive_number),
    Default("delta", 1e-8, "violation at or below which the env's reward counts a solution "
            "feasible (paper Sec. 4.2)", "a number > 0", _positive_number),
)


def number_text(v: float, digits: int | None = None) -> str:
    """A number as the map's tables and error lines print it: a whole number in plain digits
    (1000000, not 1e+06; 86400), anything else as ``:g`` (6 significant digits: 0.01, 1e-09),
    in plain digits too where that would write a positive exponent (10200000, not 1.02e+07);
    from 1e16 on as ``:g``. With `digits`, first rounded to that many significant digits
    (``number_text(25639.5, 3)`` is "25600", where ``:.3g`` writes "2.56e+04").

    Args:
        v: the number.
        digits: significant digits to round to (>= 1); None: as given (whole numbers keep
            every digit, others 6 significant).

    Returns:
        Its text.
    """
    f = float(v)
    if digits is not None and math.isfinite(f):
        f = float(f"{f:.{digits}g}")
    if f.is_integer() and abs(f) < 1e16:
        return str(int(f))  # every digit: a whole number is shown as it is
    g = f"{f:g}"
    return f"{float(g):.0f}" if "e+" in g and abs(float(g)) < 1e16 else g


def obstacle_label(kind: str, index: int, name: str | None = None) -> str:
    """An obstacle's name in messages, the one wording `check`, `plan` and `verify` share
    (it lives here, in the one module of planner_core the simulator may import): "circle 0",
    "rectangle 2", "no-fly-zone 1 'range'", "polygon 0 'barn'".

    Args:
        kind: "circle", "rectangle", "no_fly_zone" or "polygon" (its list in the map file,
            '_' written '-').
        index: its position in that list.
        name: the name the map gives it (no-fly zones and polygons), or None.

    Returns:
        "<kind> <index>", then " '<name>'" when it has a name.
    """
    base = f"{kind.replace('_', '-')} {index}"
    return f"{base} '{name}'" if name else base


def interval_text(lo: float | None, hi: float | None, lo_open: bool = False,
                  hi_open: bool = False) -> str:
    """"[0.01, 1000000]", "(0, 100000]": a range as tables and error lines print it
    (`number_text` for each end; None for an end without a bound).

    Args:
        lo, hi: the ends, or None (-inf, inf).
        lo_open, hi_open: whether each end is excluded.

    Returns:
        The interval's text.
    """
    left = "(-inf" if lo is None else ("(" if lo_open else "[") + number_text(lo)
    right = "inf)" if hi is None else number_text(hi) + (")" if hi_open else "]")
    return f"{left}, {right}"


def _ranged(name: str, value: Any, meaning: str, lo: float, hi: float,
            why: str | tuple[str, str], *, lo_open: bool = False, hi_open: bool = False,
            integer: bool = False) -> Default:
    """A map number with a physical range [lo, hi] (open ends where asked) and its reason (or
    (below, above): a reason for each side); null is valid where the default is null (the
    field is optional, with no value of its own)."""
    interval = interval_text(lo, hi, lo_open, hi_open)
    nullable = value is None
    kind = "an integer" if integer else "a number"
    valid = f"{'null or ' if nullable else ''}{kind} in {interval}"

    def ok(v: Any) -> bool:
        if v is None:
            return nullable
        if integer:
            if not _is_int(v):
                return False
        elif isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            return False
        return (v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)

    sides = why if isinstance(why, tuple) else None
    return Default(name, value, meaning, valid, ok, (lo, hi, lo_open, hi_open),
                   "; ".join(why) if sides else str(why), sides)


_WHY_RATE = "100 Gbit/s is beyond any UAV radio link"
_WHY_DATA = "1e7 Mbit (1.25 TB) takes days at any radio rate: no single flight collects more"
_WHY_PENALTY = "penalties beyond 1e9 drown every objective value in rounding"
_WHY_POWER = "a multirotor draws 0.1-10 kW; 100 kW is a helicopter's"

#: the map file's optional fields (``planner_core.model.mapio`` takes its defaults and ranges from
#: here), keyed by their JSON path; paper symbols in the meaning, the reason for each range in
#: `why`
_MAP: tuple[Default, ...] = (
    _ranged("uav.altitude", 100.0, "H, cruise altitude above take-off, m", 0.0, 10_000.0,
            "a rotary-wing UAV flies above the ground and below 10 km", lo_open=True),
    _ranged("uav.max_speed", 20.0, "v_max, m/s", 0.1, 200.0,
            ("below 0.1 m/s flight times (and the simulator's samples, one per second) grow "
             "without bound, e.g. 1e-9 m/s asked for ~745 GiB",
             "above 200 m/s: no rotary-wing UAV flies that fast")),
    _ranged("uav.acceleration", 4.0, "a, m/s^2", 0.01, 100.0,
            ("below 0.01 m/s^2 a UAV hardly reaches cruise speed on any map",
             "above 100 m/s^2: that is 10 g")),
    _ranged("uav.climb_speed", 2.5, "m/s, vertical speed of the take-off and of a climb "
            "between stops (ArduPilot's WPNAV_SPEED_UP default; PX4's MPC_Z_V_AUTO_UP is 3): "
            "set the vehicle's", 0.1, 20.0, ("below 0.1 m/s a 100 m take-off takes 17 minutes",
                                             "multirotors climb at 1-10 m/s")),
    _ranged("uav.descent_speed", 1.0, "m/s, vertical speed of the landing and of a descent "
            "between stops (PX4's MPC_Z_VEL_MAX_DN default; ArduPilot's WPNAV_SPEED_DN is "
            "1.5): set the vehicle's", 0.1, 20.0, ("below 0.1 m/s a 100 m landing takes 17 "
                                                   "minutes", "multirotors descend at 0.5-5 m/s")),
    _ranged("uav.max_hover_time", 300.0, "T_max, s per hover point", 0.0, 86_400.0,
            "no battery hovers for more than a day; T_max bounds the decision space",
            lo_open=True),
    _ranged("uav.max_hover_points", None, "I_max; null: 10 when the larger side <= 5000 m, "
            "else 20 (the paper's), or ceil(J / 2) for J sensors when that is more (at most "
            "200)", 1, 200,
            "the decision vector holds 4 x I_max numbers; the paper uses 10 or 20",
            integer=True),
    _ranged("uav.activation_threshold", 0.5, "tau: hover point i is active when eps_i >= tau",
            0.0, 1.0, "eps_i lies in [0, 1]: tau 0 makes every point active and tau 1 none, so "
            "the number of hover points could no longer vary", lo_open=True, hi_open=True),
    _ranged("radio.peak_rate", 10.0, "R_c, Mbit/s", 0.0, 1e5, _WHY_RATE, lo_open=True),
    _ranged("radio.decay", 0.01, "xi, Mbit/s per metre", 0.0, 1_000.0,
            "at 1000 Mbit/s per metre any link dies within a millimetre"),
    _ranged("radio.bandwidth", 25.0, "R_lambda, Mbit/s", 0.0, 1e5, _WHY_RATE, lo_open=True),
    _ranged("radio.required_data", 200.0, "Q_lambda, Mbit (per sensor unless it sets its own; "
            "times 1 + safety.data_margin, as planned, at most 1e7)", 0.0, 1e7, _WHY_DATA),
    _ranged("objective.alpha", 0.5, "weight of flight time against hover time", 0.0, 1.0,
            "a convex weight"),
    _ranged("objective.collision_offset", 1000.0, "mu", 0.0, 1e9, _WHY_PENALTY),
    _ranged("objective.collision_weight", 10.0, "nu, per metre", 0.0, 1e9, _WHY_PENALTY),
    _ranged("safety.clearance", 10.0, "metres kept between every leg and every obstacle: "
            "obstacles are inflated by it for planning (0: the paper's model)", 0.0, 1_000.0,
            "a kilometre of clearance closes every urban map"),
    _ranged("safety.data_margin", 0.02, "fraction added to every sensor's required data for "
            "planning (0: the paper's model)", 0.0, 1.0, "a margin above 100 % is a different "
            "requirement, not a margin"),
    # --- batteries and fleets (issue 33; docs/energy.md). A map without them plans as before.
    _ranged("uav.battery.energy_wh", None, "energy of one full battery, Wh (null: no battery, "
            "one flight as before; or give uav.endurance_s instead, not both)", 0.0, 1e5,
            "multirotor batteries hold 10-1000 Wh; 100 kWh is an electric car's", lo_open=True),
    _ranged("uav.battery.reserve", 0.2, "fraction of the battery left unused at landing: usable "
            "energy = battery x (1 - reserve)", 0.0, 0.9,
            "above 90 % almost nothing is left to fly; 20 % is common practice"),
    _ranged("uav.endurance_s", None, "hover seconds one full battery lasts, the battery's "
            "energy given as endurance_s x P(0) (null: no battery, or uav.battery.energy_wh)",
            0.0, 86_400.0, "no battery hovers for more than a day", lo_open=True),
    _ranged("uav.power.blade_profile_w", 79.86, "P0, blade profile power in hover, W (Zeng, Xu "
            "and Zhang 2019, Table I)", 0.0, 1e5, _WHY_POWER, lo_open=True),
    _ranged("uav.power.induced_w", 88.63, "P_i, induced power in hover, W (Zeng et al. 2019); "
            "hover power P(0) = P0 + P_i", 0.0, 1e5, _WHY_POWER, lo_open=True),
    _ranged("uav.power.tip_speed", 120.0, "U_tip, rotor blade tip speed, m/s (Zeng et al. "
            "2019)", 0.0, 400.0, "a blade tip beyond ~340 m/s is supersonic", lo_open=True),
    _ranged("uav.power.induced_velocity", 4.03, "v0, mean rotor induced velocity in hover, m/s "
            "(Zeng et al. 2019)", 0.0, 100.0, "rotor downwash of a UAV is a few m/s",
            lo_open=True),
    _ranged("uav.power.fuselage_drag_ratio", 0.6, "d0, fuselage drag ratio (Zeng et al. 2019)",
            0.0, 10.0, "a drag ratio is of order 1; 0 ignores the fuselage's drag"),
    _ranged("uav.power.air_density", 1.225, "rho, air density, kg/m^3 (Zeng et al. 2019: sea "
            "level, 15 C)", 0.0, 2.0, "air at sea level is ~1.2 kg/m^3, at -50 C ~1.6",
            lo_open=True),
    _ranged("uav.power.rotor_solidity", 0.05, "s, rotor solidity: blade area over disc area "
            "(Zeng et al. 2019)", 0.0, 1.0, "blades cover at most the whole disc", lo_open=True),
    _ranged("uav.power.rotor_disc_area", 0.503, "A, rotor disc area, m^2 (Zeng et al. 2019)",
            0.0, 1_000.0, "1000 m^2 is a heavy helicopter's disc", lo_open=True),
    _ranged("fleet.uavs", 1, "UAVs flying at once (each with its own batteries)", 1, 100,
            "a crew flies tens of UAVs; 100 bounds the planner's split", integer=True),
    _ranged("fleet.swap_s", 300.0, "seconds a battery swap takes at a depot between sorties",
            0.0, 86_400.0, "a swap longer than a day is no swap"),
    _ranged("fleet.separation_m", 30.0, "m, the least 3D distance between two vehicles while "
            "one is in the air, the other in the air or on the ground: verify's SEPARATION, "
            "kept by plan's staggered launches and each vehicle's own pad at a depot (this + 5 "
            "m apart) (GNSS error, the 10 m clearance and rotor wash, with room; set your "
            "airspace's rule)", 0.0, 1_000.0,
            ("0 m is a collision", "beyond a kilometre the vehicles of a map fly one after the "
             "other"), lo_open=True),
    _ranged("fleet.launch_tolerance_s", 30.0, "s, how far each sortie may take off from its "
            "planned time with SEPARATION and LINKS still holding: plan staggers the launches "
            "for it, verify's TIMING judges it (a crew launches to the half minute, not the "
            "second)", 0.0, 120.0, "beyond two minutes a crew re-plans rather than flies "
            "the schedule"),
)

#: how the sensors in range of a hover point share its radio (`radio.access`), the default
#: first: "simultaneous" is the paper's model (every sensor in range sends at once at R_ij, and
#: C3 bounds their summed rate by R_lambda); "scheduled" shares R_lambda by time slots (the
#: data taken from each sensor a variable, at most R_ij T_i, their sum at most R_lambda T_i;
#: no C3), how dense fields are served in practice
ACCESS_MODES: tuple[str, ...] = ("simultaneous", "scheduled")

#: the map file's optional fields that are a choice, not a number (JSON path -> entry)
MAP_CHOICES: dict[str, Default] = {
    "radio.access": Default(
        "radio.access", ACCESS_MODES[0], "uplink at a hover point: simultaneous (every sensor "
        "in range sends at once at R_ij; C3: their sum <= R_lambda; the paper's) or scheduled "
        "(R_lambda shared by time slots: data D_ij <= R_ij T_i, sum_j D_ij <= R_lambda T_i, "
        "no C3)", "one of " + ", ".join(ACCESS_MODES), lambda v: v in ACCESS_MODES),
}

#: how sorties are scored (`objective.goal`), the default first: "total" is the paper's f
#: summed over the sorties plus the swaps (one UAV), "makespan" the time until the last UAV
#: lands (fleets); `plan --objective` overrides the map's
GOALS: tuple[str, ...] = ("total", "makespan")
MAP_CHOICES["objective.goal"] = Default(
    "objective.goal", GOALS[0], "what several sorties minimise: total (the paper's f summed over "
    "the sorties, plus the swaps) or makespan (the time until the last UAV lands; fleets)",
    "one of " + ", ".join(GOALS), lambda v: v in GOALS)

#: the most depots a map may give (`fleet.depots`)
MAX_DEPOTS = 100
#: the most sorties the sortie planner shares one hover point's time, and one sensor's data,
#: among (`planner_core.fleet.split`): a point that needs more is left out of the split, which
#: bounds the split's size; a sensor whose data needs more (`check`'s lower bound) is a
#: SORTIE_LIMIT there, and the sortie planner refuses the map up front
SHARE_MAX = 64
#: the map file's optional fields that are lists of objects (JSON path -> entry)
MAP_LISTS: dict[str, Default] = {
    "fleet.depots": Default(
        "fleet.depots", None, "take-off, landing and battery-swap sites, [{name, x, y}] in "
        "local metres, each with its vehicles' pads [[x, y], ...] where the crew has them "
        "(`pads`; null: on a grid around it) (null: one depot `home` at the map's start; a "
        "sortie may land at the map's end)",
        f"null or 1-{MAX_DEPOTS} depots, names unique, each and each listed pad inside the "
        "area and outside every obstacle and no-fly zone",
        lambda v: v is None or (isinstance(v, list) and 1 <= len(v) <= MAX_DEPOTS)),
}

#: every run setting by name, in table order
DEFAULTS: dict[str, Default] = {d.name: d for d in _RUN}
#: every optional map field by its JSON path (``"uav.altitude"``), in table order
MAP_DEFAULTS: dict[str, Default] = {d.name: d for d in _MAP}
#: the most vehicles and sorties a sortie directory's fleet.json may list (`lamde_mission.formats.
#: fleet.read_fleet_dir`; the planner writes no more, `lamde_mission.sorties.write_sortie_dir`):
#: the vehicles are at most `fleet.uavs` (100); the sorties 1,000 in all, one per sensor at the
#: sensor limit. `verify DIR/` replays each sortie (~4 ms each: 20,000 took 83 s)
MAX_FLEET_SORTIES = 1000
MAX_FLEET_VEHICLES: int = int(MAP_DEFAULTS["fleet.uavs"].bounds[1])
#: the most corner slots K a plan may ask for (`plan --corner-slots`, the API's corner_slots):
#: what the auto rule can ask for at the largest I_max of the table, a plan's I_max corners
#: plus one per blocked leg (I_max + 1 legs): 401. The encoding grows as I_max + K (a million
#: slots took 18 GB)
MAX_CORNER_SLOTS: int = 2 * int(MAP_DEFAULTS["uav.max_hover_points"].bounds[1]) + 1

POPULATION: int = DEFAULTS["population"].value
BUDGET: int = DEFAULTS["budget"].value
CONFIGURATOR: str = DEFAULTS["configurator"].value
INIT: str = DEFAULTS["init"].value
MEMETIC: str = DEFAULTS["memetic"].value
STARTS: int = DEFAULTS["starts"].value
START_CANDIDATES: int = DEFAULTS["start_candidates"].value
DESCENTS: int = DEFAULTS["descents"].value
DESCENT_TRIALS: int = DEFAULTS["descent_trials"].value
RESTRUCTURE_TRIALS: int = DEFAULTS["restructure_trials"].value
KICK_TRIALS: int = DEFAULTS["kick_trials"].value
OTHER_TRIALS: int = DEFAULTS["other_trials"].value
DE_SHARE: float = DEFAULTS["de_share"].value
SEED: int = DEFAULTS["seed"].value
SCORE_FACTOR: float = DEFAULTS["score_factor"].value
SUITE_SEED: int = DEFAULTS["suite_seed"].value
RUNS: int = DEFAULTS["runs"].value
BEST_KNOWN_BUDGET: int = DEFAULTS["best_known_budget"].value
BEST_KNOWN_RUNS: int = DEFAULTS["best_known_runs"].value
ETA: float = DEFAULTS["eta"].value
DELTA: float = DEFAULTS["delta"].value

#: meta-training's defaults that `train --help` shows; `PPOConfig`
#: (`planner_core.learning.policy.ppo`, which imports torch) reads its fields' defaults from
#: here, so the help and the trainer cannot differ
TRAIN_DEFAULTS: Mapping[str, Any] = MappingProxyType({
    "seed": 0, "epochs": 10, "envs": 4, "population": 50, "budget": 3000,
    "imitate": "adaptive", "imitate_epochs": 8,
})

#: Metres. The one overlap tolerance of planner and sim (paper C5: a positive overlap is a
#: violation). It is the float rounding scale of the geometry on maps up to 10 km (1e-13 per
#: metre of extent, ~500 ulp of 1e4 m): the planner's kernel inflates every obstacle by at least
#: this much (`planner_core.model.geometry`), so what it calls collision-free has an exact overlap
#: of
#: 0; an L_vio at or below it counts as no collision (only legs shorter than it can have one);
#: the sim's C5 check (`sim.checks`) fails any overlap above it. Kept here, import-free, so the
#: planner's model and the sim (a second opinion that may not read the model) share it.
L_VIO_TOL: float = 1e-9


def check(name: str, value: Any) -> Any:
    """Return ``value`` if it is valid for setting ``name``; else ``ValueError`` naming it.

    Args:
        name: the setting's name, looked up in ``DEFAULTS``, ``MAP_CHOICES``, ``MAP_LISTS``,
            then ``MAP_DEFAULTS``.
        value: the candidate value.

    Returns:
        ``value`` unchanged.

    Raises:
        ValueError: ``value`` is outside the setting's range (``Default.check``).
        KeyError: ``name`` is in none of the tables.
    """
    tables = (DEFAULTS, MAP_CHOICES, MAP_LISTS)
    table = next((t for t in tables if name in t), MAP_DEFAULTS)
    return table[name].check(value)


def check_budget(value: Any, least: Any, name: str = "budget",
                 least_name: str | None = "population") -> Any:
    """Return ``value`` if it is a valid evaluation budget: an integer from ``least`` (the
    run's population: its first generation is counted in the budget) to ``MAX_BUDGET``; else
    ``ValueError`` naming ``name`` and the range. The one budget check of every run (plan,
    the sortie planner's runs, bench, train, the API's ``PlanConfig``).

    Args:
        value: the candidate budget (evaluations).
        least: the smallest budget allowed (an integer).
        name: the setting's name in the message (``"sortie_budget"``).
        least_name: what ``least`` is, named in the range ("[population (100), 10000000]");
            None: the number alone ("[1, 10000000]").

    Returns:
        ``value`` unchanged.

    Raises:
        ValueError: ``"<name>: must be an integer in [<least>, <MAX_BUDGET>], got <value!r>"``.
    """
    if not (_is_int(value) and int(least) <= int(value) <= MAX_BUDGET):
        interval = interval_text(int(least), MAX_BUDGET)
        if least_name is not None:  # "[population (100), 10000000]"
            interval = f"[{least_name} ({number_text(int(least))}), {number_text(MAX_BUDGET)}]"
        raise ValueError(f"{name}: must be an integer in {interval}, got {value!r}")
    return value


def check_run_args(
    *, population: Any, budget: Any, configurator: Any = None, init: Any = None,
    memetic: Any = None, starts: Any = None, start_candidates: Any = None,
) -> None:
    """Check a planning run's population, budget, configurator name and start mode together.

    Args:
        population: DE population size; must be an integer in [``MIN_POPULATION``,
            ``MAX_POPULATION``].
        budget: evaluation budget; must be an integer in [population, ``MAX_BUDGET``]
            (``check_budget``).
        configurator: when a str, one of ``CONFIGURATORS`` (a configurator object, or None,
            passes unchecked).
        init: when given, one of ``INIT_MODES``.
        memetic: when given, one of ``MEMETIC_MODES``.
        starts: when given, an integer >= 0.
        start_candidates: when given, an integer >= 0.

    Raises:
        ValueError: one line naming the first bad field.
    """
    check("population", population)
    check_budget(budget, population)
    if isinstance(configurator, str):
        check("configurator", configurator)
    if init is not None:
        check("init", init)
    if memetic is not None:
        check("memetic", memetic)
    if starts is not None:
        check("starts", starts)
    if start_candidates is not None:
        check("start_candidates", start_candidates)


def _cell(v: Any) -> str:
    if v is None:
        return "null"
    if isinstance(v, str):
        return f"`{v}`"
    if isinstance(v, int) and not isinstance(v, bool) and abs(v) >= 10_000:
        return f"{v:,}"
    return f"{v:.10g}" if isinstance(v, float) else str(v)


def render_markdown(table: dict[str, Default] | None = None) -> str:
    """The table as GitHub Markdown (name, default, meaning, valid range), one row per entry,
    ending with a newline.

    Args:
        table: the entries, by name; None (or empty) defaults to the run settings followed by
            the map fields (``DEFAULTS``, ``MAP_DEFAULTS``, ``MAP_CHOICES``, ``MAP_LISTS``).

    Returns:
        The Markdown table, header row first, ending with a newline.
    """
    rows = list((table or {**DEFAULTS, **MAP_DEFAULTS, **MAP_CHOICES, **MAP_LISTS}).values())
    lines = ["| name | default | meaning | valid |", "| --- | --- | --- | --- |"]
    lines += [f"| `{d.name}` | {_cell(d.value)} | {d.meaning} | {d.valid} |" for d in rows]
    return "\n".join(lines) + "\n"


#: the README lines the generated table sits between
README_MARKERS = ("<!-- defaults:begin -->\n", "<!-- defaults:end -->")


def with_table(text: str, name: str = "the text") -> str:
    """`text` with the table between its ``README_MARKERS`` rendered anew (`render_markdown`),
    the blank lines it has around the table kept as they are: the README has none (it keeps
    within its line budget; GitHub ends an HTML comment at its line), docs/reference/
    defaults.md one on each side (Python-Markdown would read a table right after the comment
    as part of it); an empty part holding a blank line gets one on each side. The one writer
    of the table: `update_readme` and docs/hooks.py (the site's build and its `--update`) both
    call it, so neither changes what the other wrote.

    Args:
        text: a page holding the markers (the first pair is filled).
        name: what to call the page in the error (a path).

    Returns:
        The page's text.

    Raises:
        ValueError: the markers are missing (or the end marker precedes the begin marker).
    """
    begin, end = README_MARKERS
    i, j = text.find(begin), text.find(end)
    if i < 0 or j < i + len(begin):
        raise ValueError(f"{name}: no {begin.strip()} ... {end} markers")
    body = text[i + len(begin) : j]
    if body.strip("\n"):  # a table (or what is left of one): its blank lines kept
        lead = len(body) - len(body.lstrip("\n"))
        trail = len(body) - len(body.rstrip("\n")) - 1  # the table ends with a newline
    else:  # empty: a blank line asks for one on each side
        lead = trail = min(len(body), 1)
    table = "\n" * lead + render_markdown() + "\n" * trail
    return text[: i + len(begin)] + table + text[j:]


def update_readme(path: str) -> bool:
    """Rewrite the table between ``README_MARKERS`` in the file at ``path`` (`with_table`;
    temp file, then rename).

    Args:
        path: the README file (UTF-8).

    Returns:
        True if it changed (False: already up to date, the file left untouched).

    Raises:
        ValueError: the markers are missing (or the end marker precedes the begin marker).
        OSError: the file cannot be read or written.
    """
    import os

    with open(path, encoding="utf-8") as fh:
        text = fh.read()
    new = with_table(text, path)
    if new == text:
        return False
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w", encoding="utf-8") as fh:
        fh.write(new)
    os.replace(tmp, path)
    return True


if __name__ == "__main__":
    # python -m planner_core.defaults            print the table as Markdown
    # python -m planner_core.defaults README.md  rewrite README's generated table in place
    import argparse
    import sys

    ap = argparse.ArgumentParser(
        prog="python -m planner_core.defaults",
        description="Print the table of every default and its limits as Markdown, or rewrite "
        "the generated table between its markers in a README.")
    ap.add_argument("readme", nargs="?", help="file whose generated table to rewrite in place")
    ns = ap.parse_args()
    if ns.readme is None:
        sys.stdout.write(render_markdown())
    else:
        try:
            changed = update_readme(ns.readme)
        except (OSError, ValueError) as exc:
            ap.exit(2, f"python -m planner_core.defaults: {exc}\n")
        print(f"{ns.readme}: " + ("updated" if changed else "up to date"))

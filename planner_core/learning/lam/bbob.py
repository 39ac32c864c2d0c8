"""D_syn: the BBOB database (paper Sec. 4.3) as lazily built ``ioh`` instances.

An instance is keyed by ``(function, dimension, instance)``: BBOB function id 1..24 (Hansen et
al., "Real-parameter black-box optimization benchmarking 2009: noiseless functions definitions"),
dimension d, and BBOB instance id (the seed of the random shift ``x_opt``, rotation and ``f_opt``
of that function). The paper builds its 14,400 instances with MetaBox's augmentation interface
(random shift and rotation per instance); BBOB's own instance ids are exactly such shift/rotation
draws, so ``ioh.get_problem(fid, instance=iid, dimension=d)`` gives the same kind of database
without MetaBox (which pins numpy < 2 and cannot share this environment).

Sizes: :data:`FULL` is the paper's setting, 24 functions x {20, 40, 80, 120, 160, 200} dims x 100
instances = 14,400. :data:`DEFAULT` is the default here (2 cores): 24 x {20, 40, 80} x 5 = 360;
the suite's tasks have d = 40 (I_max = 10) and d = 80 (I_max = 20).

Every instance is a box problem in the DE's sense: ``lower = 0``, ``upper = 1`` (the unit box,
mapped affinely to BBOB's [-5, 5]^d inside ``evaluate``), ``evaluate(X) -> (f, phi)`` with
``f = s(x) - f_opt`` (precision, >= 0; the offset ``f_opt`` is a per-instance constant of BBOB
and carries no landscape information) and ``phi = 0``.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, NamedTuple

import numpy as np

__all__ = [
    "BBOB_LOWER",
    "BBOB_UPPER",
    "FUNCTIONS",
    "MAX_DIMENSION",
    "MAX_INSTANCES",
    "MIN_DIMENSION",
    "DEFAULT",
    "FULL",
    "FUNCTION_NAMES",
    "BBOBProblem",
    "DatabaseSpec",
    "InstanceKey",
    "bbob_values",
    "check_key",
]

BBOB_LOWER = -5.0
BBOB_UPPER = 5.0

#: BBOB's noiseless function ids
FUNCTIONS = range(1, 25)
#: dimensions of a database instance (and of a training problem built from one): at least 2 (the
#: features need a spread of points), at most the largest of the paper's database (:data:`FULL`
#: stops at 200). An instance of dimension d builds a d x d rotation, so the bound also bounds
#: memory (a dimension of 1e9 would ask numpy for gigabytes).
MIN_DIMENSION = 2
MAX_DIMENSION = 200
#: instances per function and dimension (and the largest instance id in a database): the paper's
#: database has 100 (:data:`FULL`), BBOB/COCO's own suites use 15 or fewer
MAX_INSTANCES = 100
#: ioh takes an instance id as a C int
_MAX_INSTANCE_ID = 2**31 - 1

#: BBOB noiseless function names, f1..f24 (Hansen et al. 2009)
FUNCTION_NAMES = (
    "Sphere", "Ellipsoid", "Rastrigin", "BuecheRastrigin", "LinearSlope",
    "AttractiveSector", "StepEllipsoid", "Rosenbrock", "RosenbrockRotated", "EllipsoidRotated",
    "Discus", "BentCigar", "SharpRidge", "DifferentPowers", "RastriginRotated", "Weierstrass",
    "Schaffers10", "Schaffers1000", "GriewankRosenbrock", "Schwefel", "Gallagher101",
    "Gallagher21", "Katsuura", "LunacekBiRastrigin",
)  # fmt: skip


class InstanceKey(NamedTuple):
    """One database entry: BBOB function id (1..24), dimension d, BBOB instance id (>= 1)."""

    function: int
    dimension: int
    instance: int


def check_key(key: Any, where: str = "key") -> InstanceKey:
    """`key` as an :class:`InstanceKey` whose numbers ioh and memory can take.

    Args:
        key: (function, dimension, instance), integers.
        where: what names the key in an error (e.g. "objective").

    Returns:
        The key.

    Raises:
        ValueError: one line, ``"<where>.<field>: ..."``, for a function id outside 1..24, a
            dimension outside [MIN_DIMENSION, MAX_DIMENSION] or an instance id outside
            [1, 2**31 - 1].
    """
    try:
        f, d, i = (int(v) for v in key)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: expected three integers (function, dimension, instance), "
                         f"got {key!r:.60}") from None  # fmt: skip
    for name, v, low, high in (
        ("function", f, FUNCTIONS.start, FUNCTIONS.stop - 1),
        ("dimension", d, MIN_DIMENSION, MAX_DIMENSION),
        ("instance", i, 1, _MAX_INSTANCE_ID),
    ):
        if not low <= v <= high:
            raise ValueError(f"{where}.{name}: must be an integer in [{low}, {high}], got {v}")
    return InstanceKey(f, d, i)


@dataclass(frozen=True)
class DatabaseSpec:
    """Which instances D_syn holds: the product functions x dimensions x instances."""

    functions: tuple[int, ...]
    dimensions: tuple[int, ...]
    instances: tuple[int, ...]

    def __post_init__(self) -> None:
        for f in self.functions:
            if not 1 <= f <= 24:
                raise ValueError(f"functions: {f} is not a BBOB function id (1..24)")
        for d in self.dimensions:
            if not MIN_DIMENSION <= d <= MAX_DIMENSION:
                raise ValueError(f"dimensions: {d} is not in [{MIN_DIMENSION}, {MAX_DIMENSION}]")
        for i in self.instances:
            if not 1 <= i <= _MAX_INSTANCE_ID:
                raise ValueError(f"instances: {i} is not in [1, {_MAX_INSTANCE_ID}]")

    @classmethod
    def make(
        cls, functions: Any = None, dimensions: Any = None, instances: Any = None
    ) -> DatabaseSpec:
        """Build from iterables (None -> the DEFAULT's value); an int n for instances = 1..n.

        Args:
            functions: BBOB function ids (1..24).
            dimensions: dimensions, each in [MIN_DIMENSION, MAX_DIMENSION].
            instances: instance ids, or an int n for 1..n.

        Returns:
            The spec.

        Raises:
            ValueError: an id or dimension out of range.
        """
        if isinstance(instances, int):
            instances = range(1, instances + 1)
        return cls(
            tuple(int(v) for v in (functions if functions is not None else DEFAULT.functions)),
            tuple(int(v) for v in (dimensions if dimensions is not None else DEFAULT.dimensions)),
            tuple(int(v) for v in (instances if instances is not None else DEFAULT.instances)),
        )

    def keys(self) -> list[InstanceKey]:
        """All keys, ordered by dimension, then function, then instance.

        Returns:
            The `InstanceKey`s of the product, len(self) of them.
        """
        return [
            InstanceKey(f, d, i)
            for d, f, i in itertools.product(self.dimensions, self.functions, self.instances)
        ]

    def __len__(self) -> int:
        return len(self.functions) * len(self.dimensions) * len(self.instances)

    def to_json(self) -> dict[str, list[int]]:
        """The spec as a JSON object (recorded in a training-set document).

        Returns:
            {"functions", "dimensions", "instances"}: lists of ints.
        """
        return {
            "functions": list(self.functions),
            "dimensions": list(self.dimensions),
            "instances": list(self.instances),
        }


#: the paper's D_syn: 24 x 6 x 100 = 14,400 instances
FULL = DatabaseSpec(tuple(range(1, 25)), (20, 40, 80, 120, 160, 200), tuple(range(1, 101)))
#: the default on this machine: 24 x 3 x 5 = 360 instances
DEFAULT = DatabaseSpec(tuple(range(1, 25)), (20, 40, 80), tuple(range(1, 6)))


@lru_cache(maxsize=64)
def _ioh_problem(function: int, dimension: int, instance: int) -> Any:
    import ioh

    return ioh.get_problem(
        int(function), instance=int(instance), dimension=int(dimension),
        problem_class=ioh.ProblemClass.BBOB,
    )  # fmt: skip


def bbob_values(key: InstanceKey, U: np.ndarray) -> np.ndarray:
    """BBOB precision ``s(x) - f_opt`` at unit-box points ``U`` (n, d) -> (n,), x = -5 + 10 U
    (U clipped to [0, 1]; evaluated by ``ioh``).

    Args:
        key: the instance (function, dimension, instance).
        U: (n, d) unit-box points (one point (d,) is taken as (1, d)).

    Returns:
        (n,) precisions (0 at the optimum).

    Raises:
        ValueError: U's second axis is not the key's dimension.
    """
    U = np.atleast_2d(np.asarray(U, dtype=float))
    if U.shape[1] != key.dimension:
        raise ValueError(f"X has {U.shape[1]} columns, instance {key} has d={key.dimension}")
    p = _ioh_problem(*key)
    X = BBOB_LOWER + (BBOB_UPPER - BBOB_LOWER) * np.clip(U, 0.0, 1.0)
    y = np.asarray(p(np.ascontiguousarray(X)), dtype=float).reshape(-1)
    return y - float(p.optimum.y)


class BBOBProblem:
    """One BBOB instance as a box problem: unit box, ``evaluate(X) -> (f, 0)`` (module doc).

    The ``ioh`` object is built on first evaluation (creating a rotated 200-d instance costs
    tenths of a second) and shared through a small cache.
    """

    def __init__(self, key: InstanceKey | tuple[int, int, int]):
        self.key = check_key(key)
        self.dim = self.key.dimension
        self.lower = np.zeros(self.dim)
        self.upper = np.ones(self.dim)

    def __repr__(self) -> str:
        f, d, i = self.key
        return f"BBOBProblem(f{f} {FUNCTION_NAMES[f - 1]}, d={d}, instance={i})"

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Evaluate unit-box points on the instance (`bbob_values`); no constraints.

        Args:
            X: (n, d) unit-box points.

        Returns:
            (f (n,), phi (n,) zeros).

        Raises:
            ValueError: X's second axis is not the instance's dimension.
        """
        f = bbob_values(self.key, X)
        return f, np.zeros_like(f)

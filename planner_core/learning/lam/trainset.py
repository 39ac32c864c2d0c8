"""The training-set file written by ``lamde-mission lam select`` and read by :func:`load_trainset`.

Format ``lamde-trainset/1`` (JSON, keys sorted, no timestamps: same inputs, same bytes)::

    {
      "format": "lamde-trainset/1",
      "options": {                      # how the set was made (enough to redo it)
        "k": 64, "seed": 0, "selection": "global", "features": "learned",
        "n_probe": 100, "database": {"functions": [...], "dimensions": [...],
        "instances": [...], "seed": 0, "extractor": "<identity>"},
        "tasks": ["T01", ...], "task_feasible_fraction": [...], "rho": 0.05
      },
      "problems": [                     # one entry per training problem <s_k, s'_k>
        {"objective":  {"function": 8, "dimension": 40, "instance": 3},
         "constraint": {"function": 21, "dimension": 40, "instance": 1},
         "threshold": 12.3, "scale": 456.7,
         "task": "T05", "distance_f": 0.41, "distance_phi": 0.22},
        ...
      ]
    }

``objective``/``constraint`` are BBOB keys (function id 1..24, dimension, instance id);
``threshold`` and ``scale`` define ``phi = max(0, s'(x) - threshold) / scale``
(:class:`planner_core.learning.lam.query.PairProblem`). ``task`` is the target task the pair was
matched
to, ``distance_f`` the stage-1 score and ``distance_phi`` the stage-2 distance.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from planner_core.atomic import write_text_atomic
from planner_core.learning.lam.bbob import (
    FULL,
    FUNCTIONS,
    MAX_DIMENSION,
    MAX_INSTANCES,
    MIN_DIMENSION,
    InstanceKey,
)
from planner_core.learning.lam.query import PairProblem
from planner_core.textio import InputError, printable, quoted, read_json

__all__ = [
    "FORMAT",
    "MAX_PROBLEMS",
    "dumps_trainset",
    "load_trainset",
    "read_trainset",
    "write_trainset",
]

FORMAT = "lamde-trainset/1"
#: most problems in one file: `lam select` picks K <= the database's size, and the paper's whole
#: database (:data:`~planner_core.learning.lam.bbob.FULL`) holds 14,400 instances
MAX_PROBLEMS = len(FULL)


def key_json(key: InstanceKey) -> dict[str, int]:
    """A key as the file writes it: ``{"function": f, "dimension": d, "instance": i}``.

    Args:
        key: the BBOB instance key.

    Returns:
        The JSON object of the key.
    """
    return {"function": key.function, "dimension": key.dimension, "instance": key.instance}


def dumps_trainset(doc: dict[str, Any]) -> str:
    """Canonical text: sorted keys, 2-space indent, trailing newline.

    Args:
        doc: a training-set document (module doc).

    Returns:
        The file's text.
    """
    return json.dumps(doc, sort_keys=True, indent=2) + "\n"


def write_trainset(path: str | Path, doc: dict[str, Any]) -> Path:
    """Write atomically (temp file then rename): readers see the old file or the whole new one.

    Args:
        path: the file to write; its folder must exist.
        doc: a training-set document (module doc).

    Returns:
        The path written.

    Raises:
        OSError: the folder is missing or cannot be written.
    """
    return write_text_atomic(path, dumps_trainset(doc), mkdir=False)


#: (field, lowest, highest) of a BBOB key in a file: a file never holds what `lam select` cannot
#: write (function ids of BBOB, the database's dimensions and instance ids)
_KEY_RANGES = (
    ("function", FUNCTIONS.start, FUNCTIONS.stop - 1),
    ("dimension", MIN_DIMENSION, MAX_DIMENSION),
    ("instance", 1, MAX_INSTANCES),
)


def _key(entry: Any, where: str) -> InstanceKey:
    if not isinstance(entry, dict):
        raise ValueError(f"{where}: expected an object with function, dimension, instance")
    vals = []
    for name, low, high in _KEY_RANGES:
        if name not in entry:
            raise ValueError(f"{where}.{name}: missing (an integer in [{low}, {high}])")
        v = entry[name]
        if isinstance(v, bool) or not isinstance(v, int) or not low <= v <= high:
            shown = repr(v) if isinstance(v, str | bool) or v is None else str(v)
            if len(shown) > 40:
                shown = shown[:40] + "..."
            raise ValueError(f"{where}.{name}: must be an integer in [{low}, {high}], got "
                             f"{printable(shown)}")  # fmt: skip
        vals.append(v)
    return InstanceKey(*vals)


def read_trainset(path: str | Path) -> dict[str, Any]:
    """Parse and check a training-set file.

    The file is read by :func:`planner_core.textio.read_json` (at most ``limit("bytes")``, 64 MiB
    by default; UTF-8; bounded nesting), holds at most :data:`MAX_PROBLEMS` problems, and every
    BBOB key is in range (function 1..24, dimension 2..200, instance 1..100), so nothing the
    file says can make memory or time unbounded.

    Args:
        path: the training-set JSON file.

    Returns:
        The document, as parsed.

    Raises:
        ValueError: one line, ``"<path>: <field>: <problem>"``, for the first bad field (an
            :class:`planner_core.textio.InputError` for an unreadable, oversized or non-JSON
            file).
    """
    try:
        doc = read_json(path)
    except InputError as exc:
        raise InputError(exc.problem, f"{path}: {exc.where}" if exc.where else str(path)) from None
    if not isinstance(doc, dict):
        raise ValueError(f"{path}: expected a JSON object with \"format\": {FORMAT!r}")
    if doc.get("format") != FORMAT:
        found = quoted(doc["format"]) if "format" in doc else "missing"
        raise ValueError(f"{path}: format: {found}, not a version this program reads (it reads "
                         f"{FORMAT!r})")
    probs = doc.get("problems")
    if not isinstance(probs, list) or not probs:
        raise ValueError(f"{path}: problems: expected a non-empty list")
    if len(probs) > MAX_PROBLEMS:
        raise ValueError(f"{path}: problems: {len(probs):,} entries, more than the limit of "
                         f"{MAX_PROBLEMS:,} (the paper's whole database)")  # fmt: skip
    for n, p in enumerate(probs):
        where = f"{path}: problems[{n}]"
        if not isinstance(p, dict):
            raise ValueError(f"{where}: expected an object")
        obj = _key(p.get("objective"), f"{where}.objective")
        con = _key(p.get("constraint"), f"{where}.constraint")
        if obj.dimension != con.dimension:
            raise ValueError(f"{where}.constraint.dimension: {con.dimension} differs from the "
                             f"objective's {obj.dimension}")  # fmt: skip
        for name in ("threshold", "scale"):
            v = p.get(name)
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise ValueError(f"{where}.{name}: expected a number")
        if not p["scale"] > 0:
            raise ValueError(f"{where}.scale: must be > 0, got {p['scale']}")
    return doc


def load_trainset(path: str | Path) -> list[PairProblem]:
    """The training problems of a ``lam select`` file, in file order.

    Each is a box problem (``lower``, ``upper``, ``evaluate(X) -> (f, phi)``) that
    :func:`planner_core.search.de.run` and the env take unchanged.

    Args:
        path: the training-set JSON file (checked by :func:`read_trainset`).

    Returns:
        One :class:`~planner_core.learning.lam.query.PairProblem` per entry of ``problems``.

    Raises:
        ValueError: one line naming the file and the first bad field.
    """
    doc = read_trainset(path)
    out = []
    for n, p in enumerate(doc["problems"]):
        where = f"{path}: problems[{n}]"
        try:
            out.append(
                PairProblem(
                    _key(p["objective"], f"{where}.objective"),
                    _key(p["constraint"], f"{where}.constraint"),
                    float(p["threshold"]),
                    float(p["scale"]),
                )
            )
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
    return out

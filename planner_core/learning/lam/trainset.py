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
from planner_core.learning.lam.bbob import InstanceKey
from planner_core.learning.lam.query import PairProblem

__all__ = ["FORMAT", "dumps_trainset", "load_trainset", "read_trainset", "write_trainset"]

FORMAT = "lamde-trainset/1"


def key_json(key: InstanceKey) -> dict[str, int]:
    return {"function": key.function, "dimension": key.dimension, "instance": key.instance}


def dumps_trainset(doc: dict[str, Any]) -> str:
    """Canonical text: sorted keys, 2-space indent, trailing newline."""
    return json.dumps(doc, sort_keys=True, indent=2) + "\n"


def write_trainset(path: str | Path, doc: dict[str, Any]) -> Path:
    """Write atomically (temp file then rename)."""
    return write_text_atomic(path, dumps_trainset(doc))


def _key(entry: Any, where: str) -> InstanceKey:
    if not isinstance(entry, dict):
        raise ValueError(f"{where}: expected an object with function, dimension, instance")
    try:
        f, d, i = (int(entry[n]) for n in ("function", "dimension", "instance"))
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{where}: needs integer function, dimension, instance") from None
    if not 1 <= f <= 24 or d < 2 or i < 1:
        raise ValueError(f"{where}: function must be 1..24, dimension >= 2, instance >= 1")
    return InstanceKey(f, d, i)


def read_trainset(path: str | Path) -> dict[str, Any]:
    """Parse and check a training-set file; ValueError names the first bad field."""
    try:
        doc = json.loads(Path(path).read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not JSON ({exc.msg}, line {exc.lineno})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ValueError(f"{path}: format: expected {FORMAT!r}")
    probs = doc.get("problems")
    if not isinstance(probs, list) or not probs:
        raise ValueError(f"{path}: problems: expected a non-empty list")
    for n, p in enumerate(probs):
        where = f"{path}: problems[{n}]"
        if not isinstance(p, dict):
            raise ValueError(f"{where}: expected an object")
        _key(p.get("objective"), f"{where}.objective")
        _key(p.get("constraint"), f"{where}.constraint")
        for name in ("threshold", "scale"):
            if not isinstance(p.get(name), int | float):
                raise ValueError(f"{where}.{name}: expected a number")
    return doc


def load_trainset(path: str | Path) -> list[PairProblem]:
    """The training problems of a ``lam select`` file, in file order.

    Each is a box problem (``lower``, ``upper``, ``evaluate(X) -> (f, phi)``) that
    :func:`planner_core.search.de.run` and the env take unchanged. Raises ValueError on a bad file.
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

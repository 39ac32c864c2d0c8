"""Small file helpers for the benchmark: atomic writes (temp file + rename) and JSON reads."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

from planner_core.atomic import write_bytes_atomic, write_text_atomic

__all__ = [
    "dumps_json",
    "read_json",
    "write_bytes_atomic",
    "write_json_atomic",
    "write_text_atomic",
]


_NUMBER_LIST = re.compile(r"\[\s*(-?[\d.eE+-]+(?:,\s*-?[\d.eE+-]+)*)\s*\]")


def dumps_json(data: Any) -> str:
    """Indented JSON (one space) with lists of plain numbers kept on one line."""
    text = json.dumps(data, indent=1)
    return _NUMBER_LIST.sub(lambda m: "[" + ", ".join(re.split(r",\s*", m.group(1))) + "]", text)


def write_json_atomic(path: str | Path, data: Any) -> Path:
    """`dumps_json(data)` written atomically."""
    return write_text_atomic(path, dumps_json(data) + "\n")


def read_json(path: str | Path) -> dict[str, Any]:
    """A JSON object from `path`; {} when the file does not exist."""
    path = Path(path)
    if not path.exists():
        return {}
    data = json.loads(path.read_text(encoding="utf-8"))
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a JSON object")
    return data

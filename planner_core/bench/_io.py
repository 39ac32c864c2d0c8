"""Small file helpers for the benchmark: atomic writes (temp file + rename), JSON reads, and
reads of run records that may be stored gzip-compressed (`results.jsonl.gz`: the records kept
under docs/ are)."""

from __future__ import annotations

import gzip
import json
import re
from pathlib import Path
from typing import Any

from planner_core.atomic import write_bytes_atomic, write_text_atomic

__all__ = [
    "dumps_json",
    "read_json",
    "read_jsonl",
    "read_maybe_gz",
    "stored_path",
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


def stored_path(path: str | Path) -> Path:
    """`path` as stored: itself when it exists, else its gzip-compressed twin (`path` + .gz,
    or `path` without .gz) when that exists, else `path` unchanged."""
    path = Path(path)
    if path.exists():
        return path
    twin = path.with_name(path.name[:-3]) if path.name.endswith(".gz") else \
        path.with_name(path.name + ".gz")
    return twin if twin.exists() else path


def read_maybe_gz(path: str | Path) -> bytes:
    """The bytes of a file, decompressed when it is gzip-compressed (name ending in .gz);
    `results.jsonl` reads `results.jsonl.gz` when only that exists (`stored_path`)."""
    path = stored_path(path)
    data = path.read_bytes()
    return gzip.decompress(data) if path.name.endswith(".gz") else data


def read_jsonl(path: str | Path) -> list[dict[str, Any]]:
    """Every record of a JSON-lines file (blank lines skipped), compressed or not."""
    return [json.loads(line) for line in read_maybe_gz(path).decode("utf-8").splitlines()
            if line.strip()]

"""Small file helpers for the benchmark: atomic writes (temp file + rename), JSON reads, and
reads of run records that may be stored gzip-compressed (`results.jsonl.gz`: the records kept
under docs/ are)."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path
from typing import Any

from planner_core import textio
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
    """A JSON object from `path` read by the shared reader (`planner_core.textio`: a regular
    file, bounded size and depth, UTF-8, no NaN); {} when the file does not exist. ValueError
    naming the file (and the field) otherwise."""
    path = Path(path)
    if not os.path.lexists(path):
        return {}
    try:
        data = textio.read_json(path)
    except textio.InputError as exc:
        raise ValueError(f"{textio.printable(path)}: {exc}") from None
    if not isinstance(data, dict):
        raise ValueError(f"{textio.printable(path)}: expected a JSON object")
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
    `results.jsonl` reads `results.jsonl.gz` when only that exists (`stored_path`). Read by the
    shared reader: a regular file (a FIFO or device is refused, never waited on), at most
    `limit("results_bytes")` bytes, decompressed ones included; ValueError naming the file."""
    path = stored_path(path)
    try:
        return textio.read_bytes(path, limit_name="results_bytes",
                                 gunzip=path.name.endswith(".gz"))  # fmt: skip
    except textio.InputError as exc:
        raise ValueError(f"{textio.printable(path)}: {exc}") from None


def read_jsonl(path: str | Path) -> list[dict[str, Any]]:
    """Every record of a JSON-lines file (blank lines skipped), compressed or not; each line
    parsed by `textio.loads_json` (bounded depth, no NaN). ValueError naming file and line."""
    try:
        text = textio.decode_text(read_maybe_gz(path))
    except textio.InputError as exc:
        raise ValueError(f"{textio.printable(path)}: {exc}") from None
    out = []
    for n, line in enumerate(text.splitlines(), 1):
        if line.strip():
            try:
                out.append(textio.loads_json(line))
            except textio.InputError as exc:
                raise ValueError(f"{textio.printable(path)}: line {n}: {exc}") from None
    return out

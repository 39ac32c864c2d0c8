"""Small file helpers for the benchmark: atomic writes (temp file + rename), JSON reads, and
reads of run records that may be stored gzip-compressed (`results.jsonl.gz`: the records kept
under docs/ are; `read_jsonl`, `read_maybe_gz` and `stored_path` live in `planner_core.textio`,
where the schedule selector reads them too, and are re-exported here)."""

from __future__ import annotations

import datetime as _dt
import json
import os
import re
from pathlib import Path
from typing import Any

from planner_core import textio
from planner_core.atomic import write_bytes_atomic, write_text_atomic
from planner_core.textio import read_jsonl, read_maybe_gz, stored_path

__all__ = [
    "dumps_json",
    "read_json",
    "read_jsonl",
    "read_csv_column",
    "read_maybe_gz",
    "read_meta",
    "stored_path",
    "utc_now",
    "write_bytes_atomic",
    "write_json_atomic",
    "write_text_atomic",
]


_NUMBER_LIST = re.compile(r"\[\s*(-?[\d.eE+-]+(?:,\s*-?[\d.eE+-]+)*)\s*\]")


def utc_now() -> str:
    """The time now in UTC to the second, as the benchmark's files stamp it
    ("2025-01-31T12:00:00Z": a run's "started", a best-known solution's "found").

    Returns:
        "YYYY-MM-DDTHH:MM:SSZ".
    """
    return _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def dumps_json(data: Any) -> str:
    """Indented JSON (one space) with lists of plain numbers kept on one line.

    Args:
        data: a JSON-serialisable value.

    Returns:
        The JSON text, without a final newline.
    """
    text = json.dumps(data, indent=1)
    return _NUMBER_LIST.sub(lambda m: "[" + ", ".join(re.split(r",\s*", m.group(1))) + "]", text)


def write_json_atomic(path: str | Path, data: Any) -> Path:
    """`dumps_json(data)` written atomically (plus a final newline; `write_text_atomic`).

    Args:
        path: the file; a missing folder is created.
        data: a JSON-serialisable value.

    Returns:
        The path written.

    Raises:
        OSError: the folder cannot be written.
    """
    return write_text_atomic(path, dumps_json(data) + "\n")


def read_json(path: str | Path) -> dict[str, Any]:
    """A JSON object from `path` read by the shared reader (`planner_core.textio`: a regular
    file, bounded size and depth, UTF-8, no NaN); {} when the file does not exist.

    Args:
        path: the JSON file.

    Returns:
        The object ({} for a missing file).

    Raises:
        ValueError: naming the file (and the field) when it is unreadable, not such JSON, or
            not an object.
    """
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


#: the shape of what `report` and `bench` read from a benchmark's meta.json: a field's type, or
#: for an object a dict of its fields ("*": every member); absent fields and null are accepted
_META_SHAPE: dict[str, Any] = {
    "schema": int,
    "suite": str,
    "suite_absolute": str,
    "budget": int,
    "base_seed": int,
    "commands": [{"command": str}],
    "optimisers": {"*": {"description": str}},
    "stored": {"from": str},
    "ablation": {"reference": str, "driver": str,
                 "variants": {"*": {"checkpoint": str, "description": str}}},
}


def read_meta(folder: str | Path) -> dict[str, Any]:
    """`folder`/meta.json ({} when missing) read by the shared reader, with every field that
    `report` and `bench` read of the type they read (a `commands` of numbers was an
    AttributeError, a numeric `suite` a TypeError).

    Args:
        folder: the benchmark folder.

    Returns:
        The meta object ({} when meta.json is missing); absent fields and null are accepted.

    Raises:
        ValueError: naming the file and the field: a field of the wrong type, an `ablation`
            entry without `reference`, or an unreadable file (`read_json`).
    """
    from planner_core.textio import json_path, printable, quoted

    path = Path(folder) / "meta.json"
    meta = read_json(path)
    names = {dict: "an object", list: "a list", str: "a string"}
    todo: list[tuple[tuple[Any, ...], Any, Any]] = [((), meta, _META_SHAPE)]
    while todo:
        at, value, shape = todo.pop()
        if value is None and at:
            continue
        if isinstance(shape, dict):
            if not isinstance(value, dict):
                raise ValueError(f"{printable(path)}: {json_path(at)}: expected an object, got "
                                 f"{quoted(value)}")  # fmt: skip
            for k, v in value.items():
                sub = shape.get("*", shape.get(k))
                if sub is not None:
                    todo.append(((*at, k), v, sub))
        elif isinstance(shape, list):
            if not isinstance(value, list):
                raise ValueError(f"{printable(path)}: {json_path(at)}: expected a list, got "
                                 f"{quoted(value)}")  # fmt: skip
            todo.extend(((*at, i), v, shape[0]) for i, v in enumerate(value))
        elif not isinstance(value, shape):
            raise ValueError(f"{printable(path)}: {json_path(at)}: expected {names[shape]}, "
                             f"got {quoted(value)}")  # fmt: skip
    if isinstance(meta.get("ablation"), dict) and "reference" not in meta["ablation"]:
        raise ValueError(f"{printable(path)}: ablation.reference: missing")
    return meta


def read_csv_column(path: str | Path, column: str,
                    optional: tuple[str, ...] = ()) -> list[dict[str, float]]:  # fmt: skip
    """The rows of a CSV file with a header (a checkpoint's curve.csv, imitation.csv), read by
    the shared reader (regular file, bounded size, UTF-8).

    Args:
        path: the CSV file.
        column: the required column.
        optional: further columns, read when the header has them (an empty cell is 0).

    Returns:
        One dict per data row: {column: value} for `column` and the `optional` columns
        present, values finite floats.

    Raises:
        ValueError: naming the file, the row and the column: an unreadable file, not CSV, or
            a cell that is not a finite number (an empty or missing `column` cell included).
    """
    import csv
    import io
    import math

    shown = textio.printable(path)
    try:
        text = textio.read_text(path)
    except textio.InputError as exc:
        raise ValueError(f"{shown}: {exc}") from None
    try:
        reader = csv.DictReader(io.StringIO(text, newline=""))
        rows = []
        for n, row in enumerate(reader, 2):
            out = {}
            for key in (column, *optional):
                raw = row.get(key)
                if raw is None and key != column and key not in (reader.fieldnames or ()):
                    continue
                if raw in (None, "") and key != column:
                    raw = "0"
                try:
                    v = float(raw)  # type: ignore[arg-type]
                except (TypeError, ValueError):
                    raise ValueError(f"{shown}: line {n}: {key}: expected a number, got "
                                     f"{textio.quoted(raw)}") from None  # fmt: skip
                if not math.isfinite(v):
                    raise ValueError(f"{shown}: line {n}: {key}: expected a finite number, "
                                     f"got {textio.quoted(raw)}")  # fmt: skip
                out[key] = v
            rows.append(out)
    except csv.Error as exc:
        raise ValueError(f"{shown}: not a CSV file ({textio.printable(str(exc))})") from None
    return rows

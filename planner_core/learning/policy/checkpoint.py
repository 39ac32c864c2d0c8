"""Checkpoint I/O: a folder with ``weights.npz`` (float32 arrays by parameter name) and
``config.json`` (the network's :class:`~planner_core.learning.policy.network.NetConfig` plus
free-form
training metadata). Loading needs numpy and json only, never torch.

A shipped checkpoint also holds ``manifest.json`` (the training problems) and ``curve.csv``
(one row per training epoch); :func:`save` writes whatever extra files it is given.

Named checkpoints (e.g. ``"lamde-v1"``) live in ``planner_core/learning/policy/checkpoints/<name>/``
inside the package; a path to a folder works everywhere a name does.
"""

from __future__ import annotations

import io
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from planner_core.atomic import write_bytes_atomic, write_text_atomic
from planner_core.learning.policy.network import NetConfig, param_shapes

#: folder of the checkpoints shipped inside the package
SHIPPED = Path(__file__).resolve().parent / "checkpoints"
#: the checkpoint `configurator="lamde"` loads by default
DEFAULT_CHECKPOINT = "lamde-v2"
#: version 2: induced set attention blocks (NetConfig.inducing); version 1 (full attention) is
#: no longer read
FORMAT = "lamde-policy/2"


class CheckpointError(ValueError):
    """A checkpoint folder that is missing, incomplete or inconsistent (one line naming the
    file)."""


def resolve(checkpoint: str | os.PathLike[str]) -> Path:
    """The folder of a checkpoint given by shipped name or path; raises CheckpointError."""
    path = Path(checkpoint)
    if not path.is_dir():
        shipped = SHIPPED / str(checkpoint)
        if shipped.is_dir():
            path = shipped
        else:
            names = sorted(p.name for p in SHIPPED.iterdir() if p.is_dir()) if SHIPPED.is_dir() \
                else []
            raise CheckpointError(
                f"checkpoint: {checkpoint!s} is neither a folder nor a shipped checkpoint "
                f"(shipped: {', '.join(names) or 'none'})"
            )
    return path


def save(
    folder: str | os.PathLike[str],
    params: dict[str, np.ndarray],
    net: NetConfig,
    meta: dict[str, Any] | None = None,
    extra: dict[str, str] | None = None,
) -> Path:
    """Write a checkpoint folder (each file atomically); returns the folder.

    ``meta``: JSON-able training metadata stored under ``"training"`` in config.json;
    ``extra``: file name -> text for further files (manifest.json, curve.csv).
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    _check(params, net, folder)
    buf = io.BytesIO()
    np.savez(buf, **{k: np.asarray(v, dtype=np.float32) for k, v in sorted(params.items())})
    write_bytes_atomic(folder / "weights.npz", buf.getvalue())
    config = {"format": FORMAT, "net": net.to_dict(), "training": meta or {}}
    write_text_atomic(folder / "config.json", json.dumps(config, indent=2, sort_keys=True) + "\n")
    for name, text in (extra or {}).items():
        write_text_atomic(folder / name, text)
    return folder


def load(checkpoint: str | os.PathLike[str]) -> tuple[dict[str, np.ndarray], NetConfig, dict]:
    """(params, net config, full config dict) of a checkpoint; raises CheckpointError."""
    folder = resolve(checkpoint)
    try:
        config = json.loads((folder / "config.json").read_text())
    except FileNotFoundError:
        raise CheckpointError(f"checkpoint: {folder / 'config.json'} is missing") from None
    except json.JSONDecodeError as exc:
        raise CheckpointError(f"checkpoint: {folder / 'config.json'}: bad JSON ({exc})") from None
    if config.get("format") != FORMAT:
        raise CheckpointError(
            f"checkpoint: {folder / 'config.json'}: format {config.get('format')!r}, "
            f"expected {FORMAT!r}"
        )
    try:
        net = NetConfig(**config["net"])
    except (KeyError, TypeError, ValueError) as exc:
        raise CheckpointError(f"checkpoint: {folder / 'config.json'}: net: {exc}") from None
    try:
        with np.load(folder / "weights.npz") as z:
            params = {k: z[k].astype(np.float32) for k in z.files}
    except FileNotFoundError:
        raise CheckpointError(f"checkpoint: {folder / 'weights.npz'} is missing") from None
    _check(params, net, folder)
    return params, net, config


def _check(params: dict[str, np.ndarray], net: NetConfig, folder: Path) -> None:
    shapes = param_shapes(net)
    missing = sorted(set(shapes) - set(params))
    unknown = sorted(set(params) - set(shapes))
    if missing or unknown:
        raise CheckpointError(
            f"checkpoint: {folder / 'weights.npz'}: missing {missing}, unexpected {unknown}"
        )
    for k, s in shapes.items():
        if tuple(np.shape(params[k])) != s:
            raise CheckpointError(
                f"checkpoint: {folder / 'weights.npz'}: {k} has shape "
                f"{tuple(np.shape(params[k]))}, expected {s}"
            )

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
from planner_core.textio import printable, quoted

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
    """The folder of a checkpoint given by shipped name or path (a folder path is taken first).

    Args:
        checkpoint: a folder path, or the name of a checkpoint in `SHIPPED`.

    Returns:
        The checkpoint's folder.

    Raises:
        CheckpointError: neither a folder nor a shipped checkpoint (the message lists the
            shipped ones).
    """
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

    Args:
        folder: the folder (created if missing).
        params: {name: array} of the network's parameters (stored as float32).
        net: the network's configuration.
        meta: JSON-able training metadata stored under ``"training"`` in config.json.
        extra: file name -> text for further files (manifest.json, curve.csv).

    Returns:
        The folder.

    Raises:
        CheckpointError: the parameters do not match the network's names and shapes.
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
    """(params, net config, full config dict) of a checkpoint.

    Both files go through the shared reader (`planner_core.textio`: regular files only, so a
    FIFO never blocks; bounded size; config.json UTF-8 with bounded nesting). Every array of
    weights.npz is checked against the network's shapes from its .npy header before any of it
    is decompressed, so the data read is bounded by the network's size (a 2 MB archive of a
    compressed (5, 50000000) array reached 3 GB before its shape was refused).

    Args:
        checkpoint: a shipped name or a folder path (`resolve`).

    Returns:
        (params {name: array}, the `NetConfig`, config.json's object).

    Raises:
        CheckpointError: a missing folder or file, another format than `FORMAT`, a bad
            ``net`` entry, or weights that do not match the network (one line naming the
            file).
    """
    from planner_core.textio import read_json

    folder = resolve(checkpoint)
    cfg_path = folder / "config.json"
    config = _read_file(read_json, cfg_path)
    if not isinstance(config, dict):
        raise CheckpointError(f"checkpoint: {cfg_path}: expected a JSON object")
    if config.get("format") != FORMAT:
        raise CheckpointError(
            f"checkpoint: {cfg_path}: format {quoted(config.get('format'))}, "
            f"expected {FORMAT!r}"
        )
    if not isinstance(config.get("net"), dict):
        raise CheckpointError(f"checkpoint: {cfg_path}: net: expected an object")
    try:
        net = NetConfig(**config["net"])
    except (KeyError, TypeError, ValueError) as exc:
        raise CheckpointError(f"checkpoint: {cfg_path}: net: "
                              f"{printable(str(exc))[:200]}") from None  # fmt: skip
    params = _read_weights(folder / "weights.npz", net)
    _check(params, net, folder)
    return params, net, config


def _read_file(read: Any, path: Path) -> Any:
    """`read(path)` (a `planner_core.textio` reader); its InputError as a CheckpointError
    naming the file ("is missing" when it does not exist)."""
    from planner_core.textio import InputError

    try:
        return read(path)
    except InputError as exc:
        if str(exc) == "file not found":
            raise CheckpointError(f"checkpoint: {path} is missing") from None
        raise CheckpointError(f"checkpoint: {path}: {exc}") from None


def _read_weights(path: Path, net: NetConfig) -> dict[str, np.ndarray]:
    """The arrays of a weights.npz, each checked from its header (name, shape, a float dtype,
    the member's stored size) before its data is read; CheckpointError naming the file."""
    import zipfile
    import zlib

    from numpy.lib import format as npf

    from planner_core.textio import read_bytes

    data = _read_file(read_bytes, path)
    shapes = param_shapes(net)
    params: dict[str, np.ndarray] = {}
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            members = {i.filename.removesuffix(".npy"): i for i in zf.infolist()}
            missing = sorted(set(shapes) - set(members))
            unknown = sorted(set(members) - set(shapes))
            if missing or unknown:
                raise CheckpointError(f"checkpoint: {path}: missing {missing}, unexpected "
                                      f"{[printable(u)[:80] for u in unknown[:10]]}")
            for key, info in members.items():
                want = shapes[key]
                with zf.open(info) as fh:
                    version = npf.read_magic(fh)
                    if version == (1, 0):
                        shape, _fortran, dtype = npf.read_array_header_1_0(fh)
                    elif version == (2, 0):
                        shape, _fortran, dtype = npf.read_array_header_2_0(fh)
                    else:
                        raise ValueError(f"{key}: .npy format version {version} is not read")
                    if tuple(shape) != want:
                        raise CheckpointError(f"checkpoint: {path}: {key} has shape "
                                              f"{tuple(shape)}, expected {want}")
                    if dtype.hasobject or dtype.kind != "f":
                        raise CheckpointError(f"checkpoint: {path}: {key} has dtype {dtype}, "
                                              "expected floating point numbers")
                    if info.file_size > fh.tell() + int(np.prod(want)) * dtype.itemsize:
                        raise CheckpointError(f"checkpoint: {path}: {key} holds more bytes "
                                              "than its shape needs")
                with zf.open(info) as fh:
                    arr = npf.read_array(fh, allow_pickle=False)
                params[key] = np.asarray(arr).astype(np.float32)
    except CheckpointError:
        raise
    except (zipfile.BadZipFile, zipfile.LargeZipFile, ValueError, OSError, EOFError,
            zlib.error, NotImplementedError, RuntimeError) as exc:  # fmt: skip
        raise CheckpointError(f"checkpoint: {path}: not a readable numpy .npz archive "
                              f"({printable(str(exc))[:200]})") from None
    return params


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

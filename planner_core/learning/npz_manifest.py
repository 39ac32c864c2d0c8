"""A numpy archive and the JSON manifest that describes it, written so that neither is ever
half-written and a manifest never silently describes other arrays.

Shared by the learned scheduler's files: the policy's `weights.npz` + `manifest.json`
(`planner_core.learning.schedule_policy`) and the selector's `table.npz` + `manifest.json`
and `split.npz` + `split.json` (`planner_core.learning.schedule_select`).

Each file goes through a temporary file and a rename (`planner_core.atomic`), the archive
first; the manifest records the archive's sha256 under `digest_key` (`weights_sha256` for
`weights.npz`), so a run killed between the two renames (a new archive beside the old
manifest) is caught when the pair is read (`check_digest`). Manifests written before the
digest was recorded (no key) are accepted as they are.
"""

from __future__ import annotations

import hashlib
import io
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["check_digest", "digest_key", "save"]


def digest_key(npz_name: str) -> str:
    """The manifest key holding the sha256 of the archive `npz_name`.

    Args:
        npz_name: the archive's file name, e.g. "table.npz".

    Returns:
        "<stem>_sha256", e.g. "table_sha256".
    """
    return f"{Path(npz_name).stem}_sha256"


def save(folder: str | Path, npz_name: str, arrays: Mapping[str, np.ndarray],
         manifest_name: str, manifest: Mapping[str, Any], *, compressed: bool = False
         ) -> dict[str, Any]:
    """Write `folder/npz_name` (the arrays) and then `folder/manifest_name` (the manifest
    with the archive's sha256 under `digest_key(npz_name)`, JSON, indent 1, sorted keys), each
    atomically; the folder is created.

    Args:
        folder: the target folder.
        npz_name: the archive's file name.
        arrays: name -> array, stored as they are (`np.savez`, or `np.savez_compressed` when
            `compressed`); no object arrays.
        manifest_name: the manifest's file name.
        manifest: JSON-able metadata.
        compressed: deflate the archive's members.

    Returns:
        The manifest as written (with the digest).

    Raises:
        OSError: the folder cannot be written.
    """
    from planner_core.atomic import write_bytes_atomic, write_text_atomic

    buf = io.BytesIO()
    (np.savez_compressed if compressed else np.savez)(buf, **arrays)
    raw = buf.getvalue()
    written = dict(manifest, **{digest_key(npz_name): hashlib.sha256(raw).hexdigest()})
    write_bytes_atomic(Path(folder) / npz_name, raw)
    write_text_atomic(Path(folder) / manifest_name,
                      json.dumps(written, indent=1, sort_keys=True) + "\n")
    return written


def check_digest(raw: bytes, manifest: Mapping[str, Any], npz_name: str,
                 manifest_name: str) -> str | None:
    """Whether the archive bytes `raw` are those the manifest describes.

    Args:
        raw: the bytes read from `npz_name`.
        manifest: the manifest read from `manifest_name`.
        npz_name, manifest_name: the two files' names (for the message).

    Returns:
        None when they match or the manifest records no digest (written before it was
        recorded); else the problem in words, "NPZ is not the one MANIFEST describes (KEY
        differs)", for the caller to prefix with the folder.
    """
    key = digest_key(npz_name)
    want = manifest.get(key)
    if want is None or want == hashlib.sha256(raw).hexdigest():
        return None
    return f"{npz_name} is not the one {manifest_name} describes ({key} differs)"

"""Readers and writers under hostile input (an adversarial review): outputs that are devices
or FIFOs are never replaced, malformed sections are one line naming the field (exit 2, no
traceback), reads are bounded, printed text is escaped."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from lamde_mission.cli import main
from tests.conftest import MAPS

TINY = MAPS / "tiny.json"


def _run(capsys: pytest.CaptureFixture[str], *args: str | Path) -> tuple[int, str, str]:
    """`lamde-mission ARGS` in this process: (status, stdout, stderr)."""
    rc = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return rc, out, err


def _one_line(rc: int, err: str) -> str:
    assert rc == 2, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    return lines[0]


@pytest.fixture()
def tiny_geojson(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> Path:
    out = tmp_path / "tiny.geojson"
    assert _run(capsys, "map", "to-geojson", TINY, "-o", out)[0] == 0
    return out


# ----------------------------------------------------------------------------- 1: outputs


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
def test_map_commands_never_replace_a_fifo_or_make_folders(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], tiny_geojson: Path
) -> None:
    fifo = tmp_path / "out.fifo"
    os.mkfifo(fifo)
    for i, args in enumerate((("from-geojson", tiny_geojson), ("to-geojson", TINY))):
        rc, out, err = _run(capsys, "map", *args, "-o", fifo)
        assert "not a regular file" in _one_line(rc, err) and "-o/--output" in err
        assert out == "" and fifo.is_fifo()
        deep = tmp_path / f"new{i}" / "sub" / "x.json"
        rc, out, err = _run(capsys, "map", *args, "-o", deep)
        assert "--mkdir" in _one_line(rc, err) and not (tmp_path / f"new{i}").exists()
        rc, out, err = _run(capsys, "map", *args, "-o", deep, "--mkdir")
        assert rc == 0 and deep.is_file(), err

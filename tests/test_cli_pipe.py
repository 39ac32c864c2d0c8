"""A reader that closes stdout early (`lamde-mission schema | head -1`) ends the command quietly,
with status 0 and no traceback, as `grep | head` does."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from tests.conftest import MAPS, ROOT


@pytest.mark.parametrize(
    "args", [("schema",), ("check", str(MAPS / "small-demo.json"))], ids=["schema", "check"]
)
@pytest.mark.slow  # measured 9 s over 2 cases (issue 35: default suite <= 5 min)
def test_closed_pipe_exits_0_without_traceback(args: tuple[str, ...]) -> None:
    # the reader is gone before the first byte is written: deterministic, unlike a real `head`
    r, w = os.pipe()
    os.close(r)
    try:
        p = subprocess.run([sys.executable, "-m", "lamde_mission.cli", *args], stdout=w,
                           stderr=subprocess.PIPE, text=True, cwd=ROOT, timeout=120)
    finally:
        os.close(w)
    assert p.returncode == 0, p.stderr
    assert p.stderr == ""


def test_head_reads_the_first_line() -> None:
    p = subprocess.Popen([sys.executable, "-m", "lamde_mission.cli", "schema"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=ROOT)
    assert p.stdout is not None and p.stderr is not None
    first = p.stdout.readline()
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait(timeout=120) == 0 and "Traceback" not in err, err
    assert first == b"{\n"

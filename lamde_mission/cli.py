"""`lamde-mission`: the command line. Each command lives in `lamde_mission.commands.<name>`."""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from lamde_mission.commands import COMMANDS
from lamde_mission.errors import UsageError

__all__ = ["main", "build_parser"]


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with one sub-parser per available command."""
    parser = argparse.ArgumentParser(
        prog="lamde-mission",
        description="Plan UAV data-collection missions over wireless sensor networks (LAMDE) "
        "and export them as MAVLink missions.",
    )
    parser.add_argument("--version", action="version", version=_version())
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"lamde_mission.commands.{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"lamde_mission.commands.{name}":
                continue
            raise
        p = module.add_parser(sub)
        p.set_defaults(_run=module.run)
    return parser


def _version() -> str:
    try:
        from importlib.metadata import version

        return f"lamde-mission {version('lamde-mission')}"
    except Exception:  # pragma: no cover - not installed
        return "lamde-mission (not installed)"


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit status (0 ok, 1 failed/infeasible, 2 bad input)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        status = int(args._run(args) or 0)
        if sys.stdout is not None:  # None: started with fd 1 closed (`>&-`)
            sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
        return status
    except BrokenPipeError:
        return _reader_went_away()
    except UsageError as exc:
        for line in str(exc).splitlines():
            print(f"lamde-mission {args.command}: {line}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


def _reader_went_away() -> int:
    """The reader of stdout closed early (`lamde-mission schema | head -1`): stop quietly with
    status 0, as `grep | head` does. Later writes, and the interpreter's final flush, go to
    /dev/null instead of raising again (the recipe of Python's `signal` docs, SIGPIPE note)."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):  # stdout without a file descriptor (captured in tests)
        pass
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

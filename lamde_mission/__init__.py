"""lamde-mission: plan UAV data-collection missions (LAMDE) and export them as MAVLink missions.

Heavy modules load lazily, so `import lamde_mission` and `lamde-mission --help` stay fast.
"""

# no `from __future__ import annotations` here: it is an import (of __future__.py) before the
# console script's SIGINT handler below; the annotations need none
import sys

__all__ = ["plan", "plan_fleet", "Plan"]


def _quit_on_sigint(signum: int, frame: object) -> None:
    """The `lamde-mission` script's SIGINT handler until `cli.main` takes over: nothing has
    been read or written yet, so stop at once, one line, status 130 (128 + SIGINT)."""
    try:
        import posix as _os  # os without its import (the builtin module beneath it)
    except ImportError:  # Windows: no posix module
        import os as _os

    _os.write(2, b"lamde-mission: interrupted\n")
    _os._exit(130)


# the console script only (never `import lamde_mission` in a program or a notebook): a Ctrl-C
# while its imports run would otherwise end in the interpreter's KeyboardInterrupt traceback
_argv0 = (getattr(sys, "argv", None) or [""])[0]
if _argv0.replace("\\", "/").rsplit("/", 1)[-1] in ("lamde-mission", "lamde-mission.exe"):
    import _signal  # the builtin module: `signal` imports enum first, a window of its own

    # only over Python's own handler: a SIGINT ignored by whoever started us stays ignored
    if _signal.getsignal(_signal.SIGINT) is _signal.default_int_handler:
        try:  # noqa: SIM105 - contextlib is one more import before the handler
            _signal.signal(_signal.SIGINT, _quit_on_sigint)
        except ValueError:  # not the main thread: leave the handler alone
            pass


def __getattr__(name: str) -> object:  # no `typing` import: the CLI starts ~15 ms sooner
    if name == "plan":
        from lamde_mission.api import plan

        return plan
    if name == "plan_fleet":
        from lamde_mission.api import plan_fleet

        return plan_fleet
    if name == "Plan":
        from lamde_mission.result import Plan

        return Plan
    raise AttributeError(f"module 'lamde_mission' has no attribute {name!r}")

"""`lamde-mission`: the command line. Each command lives in `lamde_mission.commands.<name>`."""

from __future__ import annotations

# only `sys` (loaded with the interpreter) at the top: everything else is imported inside
# `main`'s handler, so a Ctrl-C while the program is still starting gives one line, status 130
import sys

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (~15 ms)
if TYPE_CHECKING:
    import argparse
    from collections.abc import Callable, Sequence
    from typing import NoReturn

__all__ = ["main", "build_parser"]

#: what a Ctrl-C prints (stderr) before exit status 130 (128 + SIGINT, the shell's convention)
INTERRUPTED = "lamde-mission: interrupted"


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with one sub-parser per available command.

    Returns:
        The parser (and every sub-parser, nested ones included: `add_subparsers` makes them of
        its class) a `_OneLineParser`: bad arguments give one line and exit status 2; each
        sub-parser's defaults carry `_run`, its command's `run`.
    """
    import importlib

    from lamde_mission.commands import COMMANDS

    parser = _one_line_parser()(
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


def _one_line_parser() -> type[argparse.ArgumentParser]:
    """`argparse.ArgumentParser` whose `error` prints one line, "PROG: MESSAGE" (e.g.
    "lamde-mission plan: argument --seed: invalid int value: 'abc'", control characters
    escaped by `planner_core.textio.printable`), and exits with status 2, without argparse's
    usage block (`--help` prints that, unchanged). A class made on first use, so that this
    module imports only `sys` at the top."""
    global _ONE_LINE_PARSER
    if _ONE_LINE_PARSER is None:
        import argparse

        class _OneLineParser(argparse.ArgumentParser):
            def error(self, message: str) -> NoReturn:
                from planner_core.textio import printable

                self.exit(2, f"{self.prog}: {printable(message)}\n")

        _ONE_LINE_PARSER = _OneLineParser
    return _ONE_LINE_PARSER


_ONE_LINE_PARSER: type[argparse.ArgumentParser] | None = None


def _version() -> str:
    try:
        from importlib.metadata import version

        return f"lamde-mission {version('lamde-mission')}"
    except Exception:  # pragma: no cover - not installed
        return "lamde-mission (not installed)"


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: parse `argv` and run its command.

    A Ctrl-C (KeyboardInterrupt) at any point from here on, the imports and the parsing
    included, prints `INTERRUPTED` and returns 130, without a traceback. In the console script
    the start-up handler (`lamde_mission._quit_on_sigint`: one line, status 130) comes back as
    `main` returns, so a Ctrl-C while the interpreter shuts down (atexit, threads, module
    teardown) is one line too.

    Args:
        argv: the arguments (default: `sys.argv[1:]`).

    Returns:
        The exit status: 0 ok, 1 failed/infeasible, 2 bad input, 130 interrupted.
    """
    hook = sys.unraisablehook
    sys.unraisablehook = lambda u: _unraisable(u, hook)
    restore = None
    try:
        restore = _sigint_as_keyboard_interrupt()
        return _main(argv)
    except KeyboardInterrupt:
        return _interrupted()
    except SystemError as exc:
        # a Ctrl-C inside a compiled (numba) kernel: the dispatcher returns with the
        # KeyboardInterrupt set, which Python reports as a SystemError caused by it
        if _from_ctrl_c(exc):
            return _interrupted()
        raise
    finally:
        if restore is not None:  # first: one C call, no window for a KeyboardInterrupt after
            restore()
        sys.unraisablehook = hook


def _sigint_as_keyboard_interrupt() -> Callable[[], object] | None:
    """From here on a Ctrl-C raises KeyboardInterrupt again (so atomic writers clean up and
    `main` prints one line): the script's start-up handler (`lamde_mission._quit_on_sigint`)
    is replaced by Python's default.

    Returns:
        A call that puts the start-up handler back (for the interpreter's shutdown), or None
        where it was not installed (the package imported by a program, a test).
    """
    import functools
    import signal

    from lamde_mission import _quit_on_sigint

    if signal.getsignal(signal.SIGINT) is not _quit_on_sigint:
        return None
    signal.signal(signal.SIGINT, signal.default_int_handler)
    return functools.partial(signal.signal, signal.SIGINT, _quit_on_sigint)


def _unraisable(u: object, hook: object) -> None:
    """A Ctrl-C that lands where Python cannot raise it (an import lock's weakref callback,
    a `__del__`) would be printed as "Exception ignored ..." and lost: stop there as for any
    Ctrl-C (nothing is being written at such a point). Anything else goes to `hook`."""
    if isinstance(getattr(u, "exc_value", None), KeyboardInterrupt):
        import os

        _interrupted()
        sys.stderr.flush()
        os._exit(130)
    hook(u)  # type: ignore[operator]


def _from_ctrl_c(exc: BaseException) -> bool:
    """Whether `exc` was caused by a KeyboardInterrupt (its `__cause__` / `__context__`
    chain, at most a few links)."""
    seen = 0
    e: BaseException | None = exc
    while e is not None and seen < 8:
        if isinstance(e, KeyboardInterrupt):
            return True
        e = e.__cause__ or e.__context__
        seen += 1
    return False


def _interrupted() -> int:
    import contextlib

    with contextlib.suppress(KeyboardInterrupt):  # a second Ctrl-C while saying so
        print(INTERRUPTED, file=sys.stderr)
    return 130


def _main(argv: Sequence[str] | None) -> int:
    from lamde_mission.errors import UsageError

    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    if extra:  # argparse's parse_args names the top-level program for these: name the command
        from planner_core.textio import printable

        parser.exit(2, f"{parser.prog} {_command_name(args)}: "
                    f"{printable('unrecognized arguments: ' + ' '.join(extra))}\n")
    try:
        status = int(args._run(args) or 0)
        if sys.stdout is not None:  # None: started with fd 1 closed (`>&-`)
            sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
        return status
    except BrokenPipeError:
        return _reader_went_away()
    except UsageError as exc:
        from planner_core.textio import printable

        # one problem a line: split on "\n" only, every other control character escaped (a
        # path or a name with ESC, NEL or U+2028 cannot forge a line or a terminal escape)
        for line in str(exc).split("\n"):
            print(f"lamde-mission {_command_name(args)}: {printable(line)}", file=sys.stderr)
        return 2
    except ValueError as exc:
        problems = _map_problems(exc)
        if problems is None:
            raise
        from planner_core.textio import printable

        # the map's path escaped as the UsageError branch's lines (a name with ESC or a
        # newline cannot forge a line or a terminal escape)
        where = getattr(args, "map", None)
        for line in problems:
            print(f"lamde-mission {_command_name(args)}: "
                  + (f"{printable(where)}: " if where else "")
                  + line, file=sys.stderr)  # fmt: skip
        return 2


def _command_name(args: argparse.Namespace) -> str:
    """The command as typed, its subcommand included ("map from-geojson", "lam build": a
    command with subcommands keeps the chosen one in `{command}_command`), as argparse names
    it in its own errors."""
    sub = getattr(args, f"{args.command}_command", None)
    return f"{args.command} {sub}" if sub else args.command


def _map_problems(exc: BaseException) -> list[str] | None:
    """A map's problems (`planner_core.MapError.problems`, one line each naming the field)
    when `exc` is such an error, else None: a command that meets one past its own checks
    (a map derived from the user's, such as the planning map) says so as bad input, exit
    status 2, never with a traceback. The map module is not imported here: a MapError comes
    only from it, already loaded."""
    mapio = sys.modules.get("planner_core.model.mapio")
    if mapio is None or not isinstance(exc, mapio.MapError):
        return None
    from planner_core.textio import printable

    return [printable(p) for p in exc.problems] or [printable(str(exc))]


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

"""MkDocs hooks (`mkdocs.yml`: `hooks:`): the generated parts of the reference pages.

A page marks a generated part with `<!-- NAME:begin -->` and `<!-- NAME:end -->`; at build time
the text between them is replaced by what the code says now, so the reference cannot go stale:

- `cli`: every subcommand of `lamde-mission` (nested ones too) with its `--help`, from
  `lamde_mission.cli.build_parser()`;
- `defaults`: the defaults table of `planner_core/defaults.py` (`render_markdown()`);
- `api`: one mkdocstrings `:::` entry per name in `lamde_mission.__all__`, at the module that
  defines it.

`python docs/hooks.py NAME` prints one part, as the site gets it.
"""

from __future__ import annotations

import argparse
import os
import re
from collections.abc import Callable, Iterator

MARKERS = re.compile(r"(<!-- (\w+):begin -->\n).*?(<!-- \2:end -->)", re.S)
#: the width `--help` is wrapped at on the page (argparse reads COLUMNS)
HELP_COLUMNS = 100


def iter_commands(
    parser: argparse.ArgumentParser, path: tuple[str, ...] = ()
) -> Iterator[tuple[tuple[str, ...], argparse.ArgumentParser]]:
    """(command path, parser) of `parser` and of every sub-parser below it, depth first in the
    order they were added; an alias is listed once, under its first name."""
    yield path, parser
    seen: set[int] = set()
    for action in parser._actions:  # argparse keeps its sub-parsers in a private action
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                if id(sub) not in seen:
                    seen.add(id(sub))
                    yield from iter_commands(sub, (*path, name))


def _help(parser: argparse.ArgumentParser) -> str:
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(HELP_COLUMNS)
    try:
        return parser.format_help()
    finally:
        if old is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = old


def cli_markdown() -> str:
    """Every command's `--help` as a section of its own (`## lamde-mission plan`, ...)."""
    from lamde_mission.cli import build_parser

    parts = []
    for path, parser in iter_commands(build_parser()):
        name = " ".join(("lamde-mission", *path))
        level = "#" * min(2 + max(len(path) - 1, 0), 4)
        parts.append(f"{level} `{name}`\n\n```text\n{_help(parser).rstrip()}\n```\n")
    return "\n".join(parts)


def defaults_markdown() -> str:
    """The defaults table, as `python -m planner_core.defaults` prints it."""
    from planner_core import defaults

    return defaults.render_markdown()


def api_markdown() -> str:
    """A mkdocstrings entry for every public name of `lamde_mission`, at its defining module
    (the package itself resolves them lazily, which static analysis cannot follow)."""
    import lamde_mission

    entries = []
    for name in lamde_mission.__all__:
        obj = getattr(lamde_mission, name)
        entries.append(f"::: {obj.__module__}.{obj.__qualname__}\n"
                       f"    options:\n      heading: lamde_mission.{name}\n")
    return "\n".join(entries)


GENERATORS: dict[str, Callable[[], str]] = {
    "cli": cli_markdown,
    "defaults": defaults_markdown,
    "api": api_markdown,
}


def fill(markdown: str) -> str:
    """`markdown` with every marked part replaced by its generator's output."""

    def one(m: re.Match[str]) -> str:
        gen = GENERATORS.get(m.group(2))
        if gen is None:
            return m.group(0)
        return m.group(1) + "\n" + gen().rstrip("\n") + "\n\n" + m.group(3)

    return MARKERS.sub(one, markdown)


def on_page_markdown(markdown: str, **kwargs: object) -> str:
    """MkDocs event: fill the generated parts of every page that has them."""
    return fill(markdown)


if __name__ == "__main__":
    import sys

    sys.stdout.write(GENERATORS[sys.argv[1]]() + "\n")

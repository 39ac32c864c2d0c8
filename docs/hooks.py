"""MkDocs hooks (`mkdocs.yml`: `hooks:`): the generated parts of the reference pages.

A page marks a generated part with `<!-- NAME:begin -->` and `<!-- NAME:end -->`; at build time
the text between them is replaced by what the code says now, so the site's reference cannot go
stale:

- `cli`: every subcommand of `lamde-mission` (nested ones too) with its `--help`, from
  `lamde_mission.cli.build_parser()`;
- `defaults`: the defaults table of `planner_core/defaults.py` (`render_markdown()`), written
  by that module's `with_table` (as `python -m planner_core.defaults README.md` writes the
  README's copy), which keeps the blank lines a page has around the table (none in the README,
  one each side here), so either command leaves the other's output unchanged;
- `api`: one mkdocstrings `:::` entry per name in `lamde_mission.__all__`, at the module that
  defines it.

The `cli` and `defaults` parts are also committed in the Markdown (`COMMITTED`, in the pages of
`PAGES`), so the pages read in the repository as on the site; `python docs/hooks.py --update`
rewrites them, and tests/test_docs_reference.py fails while they differ from what the code
generates. (The `api` part is mkdocstrings directives, which only the site renders.)

`python docs/hooks.py NAME` prints one part, as the site gets it.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

MARKERS = re.compile(r"(<!-- (\w+):begin -->\n).*?(<!-- \2:end -->)", re.S)
#: the width `--help` is wrapped at on the page (argparse reads COLUMNS)
HELP_COLUMNS = 100
#: the generated parts committed in the Markdown (filled again at build time all the same)
COMMITTED = ("cli", "defaults")
#: the pages holding them, relative to the repository root
PAGES = ("docs/reference/cli.md", "docs/reference/defaults.md")
ROOT = Path(__file__).resolve().parent.parent
#: the first line of the `cli` part: argparse lays out `--help` a little differently from one
#: Python to the next (3.13 writes `-o, --output OUTPUT` for `-o OUTPUT, --output OUTPUT`)
PYTHON_LINE = ("The `--help` text as Python {version}'s argparse writes it (other versions "
               "differ slightly).")


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
    # the width, and no colour whatever the terminal (Python 3.14's argparse colours on one)
    env = {"COLUMNS": str(HELP_COLUMNS), "PYTHON_COLORS": "0", "NO_COLOR": "1"}
    old = {k: os.environ.get(k) for k in env}
    os.environ.update(env)
    try:
        return parser.format_help()
    finally:
        for k, v in old.items():
            if v is None:
                del os.environ[k]
            else:
                os.environ[k] = v


def python_version() -> str:
    """`major.minor` of the Python running, as the `cli` part's first line names it."""
    return f"{sys.version_info[0]}.{sys.version_info[1]}"


def cli_markdown() -> str:
    """Every command's `--help` as a section of its own (`## lamde-mission plan`, ...)."""
    from lamde_mission.cli import build_parser

    parts = [PYTHON_LINE.format(version=python_version()) + "\n"]
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


def fill(markdown: str, names: Iterable[str] | None = None) -> str:
    """`markdown` with its marked parts replaced by their generators' output (the `defaults`
    part by `planner_core.defaults.with_table`, which keeps the page's blank lines around it).

    Args:
        markdown: a page's text.
        names: the parts to fill (None: every part with a generator); others are left as
            they are.

    Returns:
        The page's text (unchanged where it has no such part).
    """
    from planner_core import defaults

    wanted = set(GENERATORS if names is None else names)

    def one(m: re.Match[str]) -> str:
        gen = GENERATORS.get(m.group(2))
        if gen is None or m.group(2) not in wanted:
            return m.group(0)
        if m.group(2) == "defaults":  # its one writer, shared with the README's
            return defaults.with_table(m.group(0))
        return m.group(1) + "\n" + gen().rstrip("\n") + "\n\n" + m.group(3)

    return MARKERS.sub(one, markdown)


def update(path: str | Path) -> bool:
    """Rewrite the committed parts (`COMMITTED`) of the page at `path` with what the code
    generates now (a temporary file beside it, then renamed over it).

    Args:
        path: a Markdown page holding at least one of them (UTF-8).

    Returns:
        True if it changed (False: already up to date, the file left untouched).

    Raises:
        ValueError: the page has no `COMMITTED` part between its markers.
        OSError: the file cannot be read or written.
    """
    path = Path(path)
    text = path.read_text(encoding="utf-8")
    if not any(m.group(2) in COMMITTED for m in MARKERS.finditer(text)):
        raise ValueError(f"{path}: no <!-- NAME:begin --> ... <!-- NAME:end --> part of "
                         f"{', '.join(COMMITTED)}")
    new = fill(text, COMMITTED)
    if new == text:
        return False
    from planner_core.atomic import write_text_atomic

    write_text_atomic(path, new, mkdir=False)
    return True


def on_page_markdown(markdown: str, **kwargs: object) -> str:
    """MkDocs event: fill the generated parts of every page that has them."""
    return fill(markdown)


def main(argv: list[str] | None = None) -> int:
    """`python docs/hooks.py NAME` prints one part; `python docs/hooks.py --update [PAGE ...]`
    rewrites the committed parts of the pages (default: `PAGES`) and says which changed.

    Args:
        argv: the arguments (default: the command line's).

    Returns:
        The exit status: 0, or 2 for a page that cannot be read, written or has no part.
    """
    ap = argparse.ArgumentParser(
        prog="python docs/hooks.py",
        description="Print one generated part of the reference pages, or rewrite the parts "
        "committed in the Markdown (" + ", ".join(COMMITTED) + ").")
    ap.add_argument("name", nargs="?", choices=sorted(GENERATORS), help="the part to print")
    ap.add_argument("--update", nargs="*", metavar="PAGE",
                    help=f"rewrite these pages' committed parts (default: {' '.join(PAGES)})")
    ns = ap.parse_args(argv)
    if (ns.name is None) == (ns.update is None):
        ap.error("give a part to print or --update, one of the two")
    if ns.name is not None:
        sys.stdout.write(GENERATORS[ns.name]() + "\n")
        return 0
    for page in ns.update or PAGES:
        try:
            changed = update(Path(page) if ns.update else ROOT / page)
        except (OSError, ValueError) as exc:
            print(f"python docs/hooks.py: {exc}", file=sys.stderr)
            return 2
        print(f"{page}: " + ("updated" if changed else "up to date"))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""`lamde-mission schema`: print the JSON Schema of the map format."""

from __future__ import annotations

import argparse
import json


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `lamde-mission schema` (options, help).

    Args:
        sub: the subcommands of `lamde_mission.cli.build_parser`.

    Returns:
        The command's parser (`build_parser` sets `run` as its `_run`).
    """
    return sub.add_parser(
        "schema",
        help="print the JSON Schema of the map file",
        description="Print the JSON Schema (draft 2020-12) of the map file format.",
    )


def run(args: argparse.Namespace) -> int:
    """`schema`: print the map format's JSON Schema (indented JSON) on stdout.

    Args:
        args: the parsed options (none are read).

    Returns:
        0.
    """
    from planner_core.model.mapio import map_json_schema

    print(json.dumps(map_json_schema(), indent=2))
    return 0

"""Errors the CLI turns into one-line messages and exit status 2."""

from __future__ import annotations


class UsageError(Exception):
    """Bad input from the user (a map, a mission file, an option): exit status 2, no traceback."""

"""Atomic file writes for the CLI and formats (implemented in `planner_core.atomic`)."""

from planner_core.atomic import write_bytes_atomic, write_text_atomic

__all__ = ["write_text_atomic", "write_bytes_atomic"]

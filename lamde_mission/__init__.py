"""lamde-mission: plan UAV data-collection missions (LAMDE) and export them as MAVLink missions.

Heavy modules load lazily, so `import lamde_mission` and `lamde-mission --help` stay fast.
"""

from __future__ import annotations

from typing import Any

__all__ = ["plan", "Plan"]


def __getattr__(name: str) -> Any:
    if name == "plan":
        from lamde_mission.api import plan

        return plan
    if name == "Plan":
        from lamde_mission.result import Plan

        return Plan
    raise AttributeError(f"module 'lamde_mission' has no attribute {name!r}")

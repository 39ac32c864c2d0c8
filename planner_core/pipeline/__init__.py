"""The planning pipeline: `PlanConfig` (every knob, checked once), the `Stage` protocol and the
stages, the one counted `Evaluator` that owns the budget and the clock, and the default
pipeline declared once (`DEFAULT_PIPELINE`, `run_pipeline`; `WINDOW_PIPELINE`, its variant for
a window of a large plan, beside it). `lamde_mission.api.plan`, the CLI and the benchmark's
`planner` entries all run it; nothing else assembles stages.
"""

from planner_core.pipeline.config import PlanConfig
from planner_core.pipeline.evaluator import (
    BudgetExceeded,
    Evaluator,
    Progress,
    StageRecord,
    TimeLimitReached,
    Trace,
    as_evaluator,
)
from planner_core.pipeline.pipeline import (
    DEFAULT_PIPELINE,
    WINDOW_PIPELINE,
    PipelineResult,
    run_pipeline,
)
from planner_core.pipeline.stages import PlanState, Stage

__all__ = [
    "DEFAULT_PIPELINE",
    "BudgetExceeded",
    "Evaluator",
    "PipelineResult",
    "PlanConfig",
    "PlanState",
    "Progress",
    "Stage",
    "StageRecord",
    "TimeLimitReached",
    "Trace",
    "WINDOW_PIPELINE",
    "as_evaluator",
    "run_pipeline",
]

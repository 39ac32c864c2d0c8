"""Verdicts over a whole plan of sorties (issue 33): C4 and MARGIN on the data summed over
every sortie's replay (a sensor may be served by several sorties), beside each sortie's own
verdicts (`sim.checks.verify`: C1-C3, C5, ENDS, CLEAR, ENERGY).

Each sortie is replayed on its own map (the plan's map with the sortie's depots as start and
end); the whole plan is judged against the plan's map. Like the rest of the sim it imports of
`planner_core` only the defaults table. Cost: O(sorties x J).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from sim.checks import Verdict, c4_verdict, margin_verdict
from sim.replay import Timeline

__all__ = ["combined_data_verdicts"]


def combined_data_verdicts(timelines: Sequence[Timeline], map: Any) -> list[Verdict]:  # noqa: A002
    """C4 (Q_j >= Q_lambda) and MARGIN (at least (1 + safety.data_margin) x Q_lambda) on the
    data the replays collect together.

    Args:
        timelines: every sortie's replay, their sensors in the map's order.
        map: the plan's map (`sensor_ids`, `required_data`, `spec.safety`).

    Returns:
        [C4, MARGIN] verdicts; the margins as `sim.checks.verify`'s (Mbit; a fraction).

    Raises:
        ValueError: a replay whose sensors are not the map's.
    """
    ids = tuple(map.sensor_ids)
    req = np.asarray(map.required_data, dtype=float)
    q = np.zeros(len(ids))
    for tl in timelines:
        if tuple(tl.sensor_ids) != ids:
            raise ValueError("timelines: a sortie's replay has other sensors than the map")
        q = q + tl.collected
    n = len(timelines)
    sorties = "1 sortie" if n == 1 else f"{n} sorties"
    out = [c4_verdict(q, req, ids, title="Q_j >= Q_lambda (all sorties)",
                      prefix=f"over {sorties}: ", tightest="tightest")]  # fmt: skip
    want = float(getattr(getattr(map.spec, "safety", None), "data_margin", 0.0))
    out.append(margin_verdict(q, req, ids, want, suffix=" (all sorties)")[0])
    return out

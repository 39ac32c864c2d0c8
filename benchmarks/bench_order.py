"""The constructive starts' visiting order against OR-Tools' (issue 14): path time and CPU time.

For every site set the constructive pipeline builds (`planner_core.search.construct.site_sets`) on
the
given suite maps and seeds, the open path start -> sites -> end is ordered twice on the same
obstacle-aware Eq. 1 leg-time matrix (`construct.LegTimes`): by our own `routing.open_path`
(`construct.order_sites`, the planning path's) and by OR-Tools' routing solver
(`baselines.engineering.ortools_order`, the `engineering` peer's; needs the `baselines` extra).
Prints, per map, how many sets our path is longer / shorter than OR-Tools' (by more than 1e-6 s),
then the totals, the largest differences and the CPU time of each.

    python benchmarks/bench_order.py [--maps T01 ... T16] [--seeds 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", nargs="+", default=[f"T{i:02d}" for i in range(1, 17)])
    ap.add_argument("--seeds", type=int, default=3, help="seeds 0 .. N-1 (k-means inits)")
    args = ap.parse_args()

    from planner_core.bench.baselines.engineering import ortools_order
    from planner_core.model.problem import Problem
    from planner_core.model.routing import path_cost
    from planner_core.search import construct
    from planner_core.suite import suite_maps

    maps = suite_maps()
    n = longer = shorter = 0
    cpu_own = cpu_ort = 0.0
    rel: list[float] = []
    for task in args.maps:
        p = Problem(maps[task])
        legs = construct.LegTimes(p)
        m_n = m_long = m_short = 0
        for seed in range(args.seeds):
            for _label, sites in construct.site_sets(p, seed):
                if len(sites) < 2:
                    continue
                W = legs.matrix(np.vstack([p.start, sites, p.end]))
                t0 = time.process_time()
                own = construct.order_sites(p, sites, legs)
                t1 = time.process_time()
                ort = ortools_order(p, sites, legs)
                t2 = time.process_time()
                cpu_own += t1 - t0
                cpu_ort += t2 - t1
                a = path_cost(W, np.r_[0, own + 1, len(W) - 1])
                b = path_cost(W, np.r_[0, ort + 1, len(W) - 1])
                rel.append((a - b) / b * 100.0)
                m_n += 1
                m_long += a > b + 1e-6
                m_short += a < b - 1e-6
        print(f"{task}: {m_n} site sets, ours longer on {m_long}, shorter on {m_short}")
        n, longer, shorter = n + m_n, longer + m_long, shorter + m_short
    if not rel:
        print("no site sets")
        return
    print(f"total: {n} site sets, ours longer on {longer}, shorter on {shorter}; difference "
          f"{min(rel):+.2f} % .. {max(rel):+.2f} % of OR-Tools' path time")
    print(f"CPU time per set: ours {cpu_own / n * 1e3:.2f} ms, OR-Tools {cpu_ort / n * 1e3:.2f} ms")


if __name__ == "__main__":
    main()

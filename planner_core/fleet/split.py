"""Cutting a route into battery-sized sorties: the optimal split of a giant tour (Beasley 1983).

Route-first, cluster-second (J. E. Beasley, "Route first - cluster second methods for vehicle
routing", Omega 11(4), 1983; the split of C. Prins, "A simple and effective evolutionary
algorithm for the vehicle routing problem", Comput. Oper. Res. 31(12), 2004): given a visiting
order of hover points (a giant tour, e.g. the single-flight plan) with their hover times, the
best way to cut it into consecutive pieces, each flown depot -> its points -> depot on one
battery, is a shortest path over the cut positions. Here the path's states also carry the depot
the vehicle stands at (it takes off where it last landed), so the split also chooses the
depots:

    best[j, d'] = min over i < j, d of best[i, d] + swap_s [i > 0] + cost(d, P_i..P_{j-1}, d')
    subject to  energy(d, P_i..P_{j-1}, d') <= FleetSettings.budget_wh(points)

and between two pieces the vehicle may fly ferry sorties (no hover point) from depot to depot,
the least-cost chain of them (Floyd-Warshall over the depots) relaxing best[i, .].

A piece's cost is the paper's f of the sortie (alpha t_fly + (1 - alpha) t_hover; "total") or
its duration (t_fly + t_hover + take-off and landing; "makespan"); its energy the energy
module's (`planner_core.model.energy`). Legs between a depot and a point that cross an obstacle
go through visibility-graph corners (`Links`: the seeder's reduced visibility graph, the same
corners the single-flight plans use), flown as hover points with hover time 0.

A point whose hover time no sortie of it alone can fly (a sensor heavier than one battery)
is first repeated as consecutive copies sharing that time (`_shared_points`, at most
`SHARE_MAX`), so the cut may fall between them; copies one piece keeps are joined again.

`split_vehicles` cuts the tour into one consecutive chunk per vehicle first (balanced by work,
then each cut moved while the objective improves) and splits each chunk.

Cost: O(n x L x D^2) for n points, pieces of at most L points (the battery's reach) and D
depots, plus one visibility-graph route per blocked depot-point pair; nothing grows with the
sensors.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planner_core import defaults as _defaults
from planner_core.fleet.model import FleetPlan, FleetSettings, Sortie
from planner_core.model.geometry import overlap_lengths
from planner_core.model.routing.graph import CLEAR

__all__ = ["SHARE_MAX", "Links", "solo_room", "solo_need", "solo_sorties", "split_tour",
           "split_vehicles"]  # fmt: skip


class Links:
    """Obstacle-free ways between two points of a planning map: the straight leg when it is
    clear, else the shortest way through the seeder's visibility-graph corners (cached).

    Args:
        problem: the planning map's `planner_core.model.problem.Problem` (obstacles, seeder).
    """

    def __init__(self, problem: Any) -> None:
        self.problem = problem
        self.obstacles = problem.obstacles
        self._cache: dict[bytes, np.ndarray | None] = {}

    def clear(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Whether each leg a -> b is collision-free (overlap with the obstacles <= `CLEAR`).

        Args:
            a, b: (n, 2) the legs' ends, m.

        Returns:
            (n,) bool.
        """
        return overlap_lengths(np.asarray(a, dtype=float), np.asarray(b, dtype=float),
                               self.obstacles) <= CLEAR  # fmt: skip

    def way(self, a: np.ndarray, b: np.ndarray) -> np.ndarray | None:
        """Corners to fly through from a to b, in order: none when the leg is clear, else the
        shortest way over the seeder's visibility graph. Cached both ways round.

        Args:
            a, b: (2,) the ends, m.

        Returns:
            (k, 2) corners, m (k = 0 when the leg is clear); None when the graph joins them by
            no way.
        """
        a = np.asarray(a, dtype=float).reshape(2)
        b = np.asarray(b, dtype=float).reshape(2)
        key = a.tobytes() + b.tobytes()
        if key in self._cache:
            return self._cache[key]
        back = b.tobytes() + a.tobytes()
        if back in self._cache:
            w = self._cache[back]
            return None if w is None else w[::-1].copy()
        if bool(self.clear(a[None], b[None])[0]):
            out: np.ndarray | None = np.zeros((0, 2))
        else:
            seeder = self.problem.seeder
            g = seeder.graph
            out = None
            if g.n:
                src, dst = seeder.connect(np.vstack([a, b]))
                length, path = g.route(src, dst)
                if path and np.isfinite(length):
                    out = g.nodes[path].copy()
        self._cache[key] = out
        return out

    def join(self, pts: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """A tour through pts with corners (hover time 0) put into its blocked legs (`way`).

        Args:
            pts: (n, 2) the tour's points, m.
            times: (n,) their hover times, s.

        Returns:
            (points (n', 2) m, times (n',) s), n' >= n, copies; None when some leg cannot
            be routed.
        """
        pts = np.asarray(pts, dtype=float).reshape(-1, 2)
        times = np.asarray(times, dtype=float).reshape(-1)
        if len(pts) < 2:
            return pts.copy(), times.copy()
        ok = self.clear(pts[:-1], pts[1:])
        if ok.all():
            return pts.copy(), times.copy()
        P, T = [pts[:1]], [times[:1]]
        for i in range(1, len(pts)):
            if not ok[i - 1]:
                w = self.way(pts[i - 1], pts[i])
                if w is None:
                    return None
                P.append(w)
                T.append(np.zeros(len(w)))
            P.append(pts[i : i + 1])
            T.append(times[i : i + 1])
        return np.vstack(P), np.concatenate(T)


def _connections(
    st: FleetSettings, links: Links, P: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[list[Any]]]:
    """Per depot d and point i: time (s), energy (Wh, no vertical) and corner count of the
    way d -> P_i, and the corners; inf where there is none. Each point's column is kept on
    `links` (keyed by its coordinates), so splits of re-ordered tours reuse it."""
    D, n = len(st.depots), len(P)
    cache: dict[bytes, tuple[np.ndarray, np.ndarray, np.ndarray, list[Any]]]
    cache = links.__dict__.setdefault("_columns", {})
    new = [i for i in range(n) if P[i].tobytes() not in cache]
    if new:
        Q = P[new]
        clear = np.array([links.clear(np.repeat(st.depots[d][None], len(Q), axis=0), Q)
                          for d in range(D)]).reshape(D, len(Q))  # fmt: skip
        for q, i in enumerate(new):
            col_t, col_e = np.full(D, np.inf), np.full(D, np.inf)
            col_n = np.zeros(D, dtype=int)
            col_w: list[Any] = [None] * D
            for d in range(D):
                w = np.zeros((0, 2)) if clear[d, q] else links.way(st.depots[d], P[i])
                if w is None:
                    continue
                path = np.vstack([st.depots[d], w, P[i]])
                seg = np.hypot(*np.diff(path, axis=0).T)
                col_t[d] = float(st.leg_times(seg).sum())
                col_e[d] = float(st.leg_energies(seg).sum())
                col_n[d] = len(w)
                col_w[d] = w
            cache[P[i].tobytes()] = (col_t, col_e, col_n, col_w)
    cols = [cache[P[i].tobytes()] for i in range(n)]
    ct = np.array([c[0] for c in cols]).T.reshape(D, n)
    ce = np.array([c[1] for c in cols]).T.reshape(D, n)
    nc = np.array([c[2] for c in cols]).T.reshape(D, n)
    ways = [[cols[i][3][d] for i in range(n)] for d in range(D)]
    return ct, ce, nc, ways


def split_tour(
    st: FleetSettings,
    links: Links,
    P: np.ndarray,
    T: np.ndarray,
    *,
    starts: tuple[int, ...] | None = None,
    goal: str | None = None,
) -> list[Sortie] | None:
    """The best cut of the tour P (n, 2) with hover times T (n,) s into sorties (module
    docstring): consecutive pieces, each depot -> its points -> depot within the battery; the
    first leaves one of `starts` (default `st.start_depots`), each later one the depot the
    last landed at.

    Args:
        st: the fleet's settings (depots, battery, swap time, weights).
        links: obstacle-free ways on the planning map.
        P, T: the tour's points (m) and hover times (s); its own legs must be clear.
        starts: depots the first sortie may leave.
        goal: "total" (pieces cost their f) or "makespan" (their duration); default st's.

    Returns:
        The sorties in flying order, or None when some point cannot be flown on one battery
        from any depot (with its hover time) or the tour is empty.
    """
    P = np.asarray(P, dtype=float).reshape(-1, 2)
    T = np.asarray(T, dtype=float).reshape(-1)
    if len(P) == 0:
        return None
    shared = _shared_points(st, links, P, T)
    if shared is None:
        return None
    repeated = len(shared[0]) > len(P)  # copies to join back where one piece keeps several
    P, T = shared
    n, D = len(P), len(st.depots)
    goal = goal or st.goal
    wf, wh, per = (st.alpha, 1.0 - st.alpha, 0.0) if goal == "total" else (1.0, 1.0, st.vertical_s)
    starts = st.start_depots if starts is None else starts
    ct, ce, nc, ways = _connections(st, links, P)
    seg = np.hypot(*np.diff(P, axis=0).T) if n > 1 else np.zeros(0)
    CT = np.concatenate([[0.0], np.cumsum(st.leg_times(seg))])  # (n,) flight to P_i from P_0
    CE = np.concatenate([[0.0], np.cumsum(st.leg_energies(seg))])
    CH = np.concatenate([[0.0], np.cumsum(T)])  # (n + 1,)
    h = st.hover_w / 3600.0
    cap = st.usable_wh
    # the ferries that fit depend on the battery too (`budget_wh`): a planner that tries
    # other batteries on the same links (`_Planner.enough_battery`) must not reuse them
    fkey = ("_ferries", wf, per, st.usable_wh, st.pad_wh)
    if fkey not in links.__dict__:
        links.__dict__[fkey] = _ferries(st, links, wf, per)
    fc, fnext, fways = links.__dict__[fkey]
    best = np.full((n + 1, D), np.inf)  # reached by a piece (or the start)
    prev = np.full((n + 1, D, 2), -1, dtype=int)
    ferry = np.full((n + 1, D), -1, dtype=int)  # the depot a ferry chain left, else -1
    best[0, list(starts)] = 0.0
    for i in range(n):
        if not np.isfinite(best[i]).any():
            continue
        # ferry flights from where a piece landed to another depot, before the next piece
        via = best[i][:, None] + fc  # (D, D')
        src = np.argmin(via, axis=0)
        here = best[i].copy()
        moved = via[src, np.arange(D)] < best[i]
        here[moved] = via[src[moved], np.flatnonzero(moved)]
        ferry[i, moved] = src[moved]
        # the longest piece from P_i: its interior energy alone (no way in or out) fits
        inner = st.vertical_wh + (CE[i:n] - CE[i]) + h * (CH[i + 1 : n + 1] - CH[i])
        L = int(np.searchsorted(inner, cap, side="right"))
        if L == 0:
            continue
        j = np.arange(i + 1, i + L + 1)  # piece P_i .. P_{j-1}
        fly = (
            ct[:, i][:, None, None]
            + (CT[j - 1] - CT[i])[None, :, None]
            + ct[:, j - 1].T[None, :, :]
        )  # (D, L, D')
        hov = (CH[j] - CH[i])[None, :, None]
        en = (
            st.vertical_wh
            + ce[:, i][:, None, None]
            + (CE[j - 1] - CE[i])[None, :, None]
            + ce[:, j - 1].T[None, :, :]
            + h * hov
        )
        count = (j - i)[None, :, None] + nc[:, i][:, None, None] + nc[:, j - 1].T[None, :, :]
        budget = st.budget_wh(count)
        cost = here[:, None, None] + (st.swap_s if i > 0 else 0.0) + wf * fly + wh * hov + per
        cost = np.where(en <= budget, cost, np.inf)
        dbest = np.argmin(cost, axis=0)  # (L, D')
        cmin = np.take_along_axis(cost, dbest[None], axis=0)[0]
        better = cmin < best[j]
        if better.any():
            rows, cols = np.nonzero(better)
            best[j[rows], cols] = cmin[rows, cols]
            prev[j[rows], cols, 0] = i
            prev[j[rows], cols, 1] = dbest[rows, cols]
    if not np.isfinite(best[n]).any():
        return None
    d_end = int(np.argmin(best[n]))
    out: list[Sortie] = []
    j = n
    while j > 0:
        i, d = int(prev[j, d_end, 0]), int(prev[j, d_end, 1])
        w_out = ways[d][i]
        w_in = ways[d_end][j - 1][::-1]
        pts = np.vstack([w_out, P[i:j], w_in])
        times = np.concatenate([np.zeros(len(w_out)), T[i:j], np.zeros(len(w_in))])
        piece = Sortie(d, d_end, pts, times)
        out.append(_merged_repeats(piece, float(st.uav.max_hover_time)) if repeated else piece)
        if ferry[i, d] >= 0:  # the ferry flights that brought the vehicle to d, last first
            hops = _hops(fnext, int(ferry[i, d]), d)
            for a, b in reversed(list(zip(hops[:-1], hops[1:], strict=True))):
                w = fways[a][b]
                out.append(Sortie(a, b, w, np.zeros(len(w))))
            d = int(ferry[i, d])
        j, d_end = i, d
    return out[::-1]


#: the most sorties one hover point's time is shared among (`planner_core.defaults`)
SHARE_MAX = _defaults.SHARE_MAX


def solo_room(st: FleetSettings, links: Links, P: np.ndarray) -> np.ndarray:
    """Per point, the most energy (Wh) a sortie of that point alone leaves for its hover: over
    the depot pairs (out of d, back to d'), the budget for its points (`budget_wh`) less the
    climb, the landing and the ways there and back; -inf where no depot reaches it.

    Args:
        st, links: as `split_tour`.
        P: points (n, 2), m.

    Returns:
        (n,) Wh (<= 0: no sortie of the point alone fits the battery, even with no hover).
    """
    _, ce, nc, _ = _connections(st, links, np.asarray(P, dtype=float).reshape(-1, 2))
    out_e, back_e = ce[:, None, :], ce[None, :, :]  # (D, 1, n), (1, D, n)
    count = 1 + nc[:, None, :] + nc[None, :, :]
    budget = st.budget_wh(count)
    return np.max(budget - st.vertical_wh - out_e - back_e, axis=(0, 1))


def solo_need(
    st: FleetSettings, links: Links, P: np.ndarray, T: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per point, the least usable energy (Wh: battery x (1 - reserve), `FleetSettings.
    usable_for`) a sortie of that point alone needs to fly it with T s of hover: the take-off
    and landing, the way out of depot a and back to depot b (the pair needing least) and the
    hover at P(0). What `solo_room` measures against the battery, said as the battery needed.

    Args:
        st, links: as `split_tour`.
        P: points (n, 2), m; T: (n,) s of hover in that sortie.

    Returns:
        (need (n,) Wh, inf where no depot reaches the point; a (n,), b (n,) the depots'
        indices).
    """
    P = np.asarray(P, dtype=float).reshape(-1, 2)
    _, ce, nc, _ = _connections(st, links, P)
    D, n = ce.shape
    spend = st.vertical_wh + ce[:, None, :] + ce[None, :, :] + st.hover_wh(T)  # (D, D, n)
    need = st.usable_for(spend, 1 + nc[:, None, :] + nc[None, :, :]).reshape(D * D, n)
    pair = np.argmin(need, axis=0)
    return need[pair, np.arange(n)], pair // D, pair % D


def solo_sorties(st: FleetSettings, room: np.ndarray, T: np.ndarray) -> np.ndarray:
    """The least sorties among which each point's hover time T (s) can be shared: k such that
    T / k of hover fits the point's `room` (Wh, `solo_room`) and stays within T_max (C2);
    inf where the room is not positive.

    Args:
        st: the fleet's settings (P(0), T_max).
        room: (n,) Wh; T: (n,) s.

    Returns:
        (n,) float: whole numbers >= 1, or inf.
    """
    room = np.asarray(room, dtype=float)
    need = st.hover_wh(T)  # Wh each point's hover takes
    with np.errstate(divide="ignore", invalid="ignore"):
        k = np.where(room > 0.0, np.ceil(need / np.where(room > 0.0, room, 1.0) - 1e-9), np.inf)
    k = np.maximum(k, np.ceil(np.asarray(T, dtype=float) / float(st.uav.max_hover_time) - 1e-9))
    return np.maximum(k, 1.0)


def _shared_points(
    st: FleetSettings, links: Links, P: np.ndarray, T: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """The tour with every point whose hover time no single sortie can fly repeated: k
    consecutive copies at the same place, T_i / k s each, k the least for which a sortie of
    that point alone (out of and back to its best depots) fits the battery and T_i / k is
    within T_max (C2: `FleetSettings.uav.max_hover_time`; `solo_sorties`); the split then
    cuts between the copies and C4 is met over the sorties (the LP across sorties re-times
    them). None when a point cannot be flown even with 0 s of hover or would need more than
    `SHARE_MAX` sorties.

    Args:
        st, links: as `split_tour`.
        P, T: the tour (n, 2) m and its hover times (n,) s.

    Returns:
        (P', T'), (n', 2) and (n',), n' >= n; P and T themselves when no point needs sharing.
    """
    k = solo_sorties(st, solo_room(st, links, P), T)
    if np.any(k > SHARE_MAX):  # unreachable, or a swarm of sorties for one point
        return None
    k = k.astype(int)
    if np.all(k == 1):
        return P, T
    return np.repeat(P, k, axis=0), np.repeat(T / k, k)


def _merged_repeats(s: Sortie, t_max: float) -> Sortie:
    """The sortie with consecutive copies of one point (`_shared_points`) joined into one
    point hovering their summed time, as long as the sum stays within t_max (C2; a copy
    beyond it stays a point of its own at the same place)."""
    pts, times = np.asarray(s.points), np.asarray(s.times)
    if len(pts) < 2 or not np.any(np.all(pts[1:] == pts[:-1], axis=1)):
        return s
    out_p, out_t = [pts[0]], [float(times[0])]
    for p, t in zip(pts[1:], times[1:], strict=True):
        if np.array_equal(p, out_p[-1]) and out_t[-1] + t <= t_max:
            out_t[-1] += float(t)
        else:
            out_p.append(p)
            out_t.append(float(t))
    return Sortie(s.start, s.end, np.array(out_p), np.array(out_t))


def _ferries(
    st: FleetSettings, links: Links, wf: float, per: float
) -> tuple[np.ndarray, np.ndarray, list[list[Any]]]:
    """Ferry flights: sorties with no hover point that move a vehicle from one depot to
    another (its next sortie then leaves there). Returns the least cost (D, D) of a chain of
    them (each wf x its flight time + per + swap_s; inf where no chain fits the battery, 0 on
    the diagonal), the chains' next hops (D, D) and each direct ferry's corners."""
    D = len(st.depots)
    cost = np.full((D, D), np.inf)
    ways: list[list[Any]] = [[None] * D for _ in range(D)]
    for a in range(D):
        for b in range(D):
            if a == b:
                continue
            w = links.way(st.depots[a], st.depots[b])
            if w is None:
                continue
            path = np.vstack([st.depots[a], w, st.depots[b]])
            seg = np.hypot(*np.diff(path, axis=0).T)
            energy = st.vertical_wh + float(st.leg_energies(seg).sum())
            if energy <= st.budget_wh(len(w)):
                cost[a, b] = wf * float(st.leg_times(seg).sum()) + per + st.swap_s
                ways[a][b] = w
    nxt = np.where(np.isfinite(cost), np.arange(D)[None, :], -1)
    np.fill_diagonal(cost, 0.0)
    np.fill_diagonal(nxt, np.arange(D))
    for k in range(D):  # Floyd-Warshall
        alt = cost[:, k][:, None] + cost[k, :][None, :]
        better = alt < cost
        cost = np.where(better, alt, cost)
        nxt = np.where(better, nxt[:, k][:, None], nxt)
    return cost, nxt, ways


def _hops(nxt: np.ndarray, a: int, b: int) -> list[int]:
    """The depots of the ferry chain a -> b (Floyd-Warshall next hops), a and b included."""
    out = [a]
    while out[-1] != b:
        out.append(int(nxt[out[-1], b]))
    return out


def split_vehicles(
    st: FleetSettings,
    links: Links,
    P: np.ndarray,
    T: np.ndarray,
    *,
    vehicles: int | None = None,
    goal: str | None = None,
) -> FleetPlan | None:
    """The tour P (n, 2), T (n,) shared out among `vehicles` (default `st.uavs`) as
    consecutive chunks, each cut into sorties by `split_tour`: the chunks first balanced by
    their work (flight along the tour plus hover), then each cut moved by 8, 4, 2, 1 points
    while the plan's objective (`FleetPlan.objective`) improves.

    Args:
        st: the fleet's settings (depots, battery, swap time, weights).
        links: obstacle-free ways on the planning map.
        P, T: the tour's points (n, 2), m, and hover times (n,), s; its own legs must be clear.
        vehicles: chunks to cut into (at most n); default `st.uavs`.
        goal: "total" or "makespan", as `split_tour`; default st's.

    Returns:
        The plan (no LP run on it yet), or None when some chunk cannot be split.
    """
    P = np.asarray(P, dtype=float).reshape(-1, 2)
    T = np.asarray(T, dtype=float).reshape(-1)
    n = len(P)
    k = max(1, min(int(vehicles or st.uavs), n))
    cache: dict[tuple[int, int], list[Sortie] | None] = {}

    def chunk(lo: int, hi: int) -> list[Sortie] | None:
        if (lo, hi) not in cache:
            cache[(lo, hi)] = split_tour(st, links, P[lo:hi], T[lo:hi], goal=goal)
        return cache[(lo, hi)]

    def plan_of(cuts: list[int]) -> FleetPlan | None:
        bounds = [0, *cuts, n]
        vs = []
        for lo, hi in zip(bounds[:-1], bounds[1:], strict=True):
            s = chunk(lo, hi)
            if s is None:
                return None
            vs.append(s)
        return FleetPlan(st, vs)

    if k == 1:
        s = chunk(0, n)
        return None if s is None else FleetPlan(st, [s])
    seg = np.hypot(*np.diff(P, axis=0).T)
    work = np.concatenate([[0.0], np.cumsum(st.leg_times(seg))]) + np.cumsum(T)
    cuts = [int(np.clip(np.searchsorted(work, work[-1] * q / k), 1, n - 1)) for q in range(1, k)]
    cuts = sorted(set(cuts))
    best = plan_of(cuts)
    score = best.objective(goal) if best is not None else (np.inf, np.inf)
    for step in (8, 4, 2, 1):
        improved = True
        while improved:
            improved = False
            for c in range(len(cuts)):
                for sgn in (-1, 1):
                    trial = list(cuts)
                    trial[c] += sgn * step
                    lo = trial[c - 1] if c > 0 else 0
                    hi = trial[c + 1] if c + 1 < len(trial) else n
                    if not lo < trial[c] < hi:
                        continue
                    p = plan_of(trial)
                    if p is not None and p.objective(goal) < score:
                        best, score, cuts, improved = p, p.objective(goal), trial, True
    return best

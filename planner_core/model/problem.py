"""The paper's optimisation model (Sec. 3 and the constraint handling of Sec. 4.1), vectorised.

A decision vector is x = [x_i, y_i, t_i, eps_i] for i = 1..I_max; hover point i is active when
eps_i >= tau (variable-length encoding) or always (fixed-length mode, the paper's LAMDE-F).
`Problem.evaluate` scores a whole population at once; `Problem.breakdown` explains one solution.
"""

from __future__ import annotations

from dataclasses import replace
from functools import cached_property
from typing import Any

import numpy as np

from planner_core.model.formulas import ModelParams, collision_penalty, penalised_score
from planner_core.model.geometry import overlap_lengths
from planner_core.model.kernels import model_terms, scheduled_flow
from planner_core.model.mapio import Map, load_map
from planner_core.model.seeding import Seeder
from planner_core.textio import counted

__all__ = ["Problem"]


class Problem:
    """The UAV data-collection problem on one map: bounds, `evaluate(X) -> (f, phi)`, breakdown."""

    def __init__(
        self,
        map: Map | str | dict,  # noqa: A002
        *,
        variable_length: bool = True,
        corner_slots: int = 0,
    ):
        """The problem on `map`.

        Args:
            map: a loaded map, a map file path or its dict.
            variable_length: False: every slot is flown (the paper's LAMDE-F).
            corner_slots: K >= 0 extra slots for detour corners (the product's mode, issue 31;
                0, the default, is the paper's model unchanged): the encoding holds
                I_max + K slots, and phi gains v6 = the number of active points with t > 0
                beyond I_max, so at most I_max hover points are feasible while points of
                exactly 0 s (corners, written as NAV_WAYPOINT) use the rest.

        Raises:
            ValueError: corner_slots not an integer >= 0, or > 0 in fixed-length mode.
        """
        self.map = load_map(map)
        self.variable_length = bool(variable_length)
        if isinstance(corner_slots, bool) or not isinstance(corner_slots, (int, np.integer)) \
                or corner_slots < 0:
            raise ValueError(f"corner_slots: must be an integer >= 0, got {corner_slots!r}")
        if corner_slots and not self.variable_length:
            raise ValueError("corner_slots: fixed-length mode flies every slot; use 0")
        self.corner_slots = int(corner_slots)
        #: the model's parameters (`planner_core.model.formulas.ModelParams`), shared with the
        #: seeder,
        #: the polish LP and the compiled kernels; the attributes below are its fields
        mp = ModelParams.from_map(self.map)
        #: I_max, the most hover points (t > 0) a feasible plan holds
        self.hover_limit = mp.n_points
        if self.corner_slots:
            mp = replace(mp, n_points=mp.n_points + self.corner_slots)
        self.model = mp
        #: slots of the encoding: I_max, plus `corner_slots` in the product's corner mode
        self.n_points = mp.n_points
        self.dim = 4 * self.n_points
        block = np.array([mp.width, mp.height, mp.t_max, 1.0])
        self.lower = np.zeros(self.dim)
        self.upper = np.tile(block, self.n_points)
        self.tau = mp.tau
        self.altitude = mp.altitude
        self.v_max = mp.v_max
        self.accel = mp.accel
        self.t_max = mp.t_max
        self.peak_rate = mp.peak_rate
        self.decay = mp.decay
        self.bandwidth = mp.bandwidth
        #: `radio.access` "scheduled": R_lambda shared by time slots, no C3, each sensor's data
        #: the most the hover times can take (`planner_core.model.kernels.scheduled_flow`)
        self.scheduled = mp.access == "scheduled"
        self.alpha = mp.alpha
        self.mu = mp.mu
        self.nu = mp.nu
        self.start = mp.start
        self.end = mp.end
        self.sensors = mp.sensors
        self.required = mp.required
        self.obstacles = self.map.obstacles

    def __repr__(self) -> str:
        mode = "variable" if self.variable_length else "fixed"
        corners = f", {counted(self.corner_slots, 'corner slot')}" if self.corner_slots else ""
        return f"Problem({self.map.name!r}, dim={self.dim}, {mode}-length{corners})"

    def _excess_hover(self, X: np.ndarray) -> np.ndarray:
        """v6 (n,): active points with t > 0 beyond I_max (0 without corner slots). A point of
        exactly 0 s is a corner: the writer flies it through as NAV_WAYPOINT."""
        if not self.corner_slots:
            return np.zeros(len(X))
        _pts, times, active = self._split(X)
        n_hover = (active & (times > 0.0)).sum(axis=1)
        return np.maximum(n_hover - self.hover_limit, 0).astype(float)

    # ------------------------------------------------------------------ decoding
    def _split(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        X = np.clip(np.asarray(X, dtype=float), self.lower, self.upper)
        n = X.shape[0]
        blocks = X.reshape(n, self.n_points, 4)
        pts = blocks[:, :, :2]
        times = blocks[:, :, 2]
        if self.variable_length:
            active = blocks[:, :, 3] >= self.tau
        else:
            active = np.ones((n, self.n_points), dtype=bool)
        return pts, times, active

    def _legs(self, pts: np.ndarray, active: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Leg start and end points (n, I_max + 1, 2): start, active points in order, end;
        the unused tail is padded with zero-length legs at the end point."""
        n, m = active.shape
        order = np.argsort(~active, axis=1, kind="stable")
        compact = np.take_along_axis(pts, order[:, :, None], axis=1)
        count = active.sum(axis=1)
        pad = np.arange(m)[None, :] >= count[:, None]
        compact = np.where(pad[:, :, None], self.end, compact)
        nodes = np.empty((n, m + 2, 2))
        nodes[:, 0] = self.start
        nodes[:, 1:-1] = compact
        nodes[:, -1] = self.end
        return nodes[:, :-1], nodes[:, 1:]

    def rates(self, pts: np.ndarray) -> np.ndarray:
        """R_ij = max(R_c - xi * sqrt(|p_i - s_j|^2 + H^2), 0), shape (..., I, J) in Mbit/s.

        Args:
            pts: hover points (m), shape (..., I, 2).

        Returns:
            R (Mbit/s, >= 0) to this map's sensors, shape (..., I, J) (`ModelParams.rates`).
        """
        return self.model.rates(pts)

    # ------------------------------------------------------------------ evaluation
    def _overlap(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Length of each leg a -> b inside obstacles (the compiled kernel; see geometry.py)."""
        return overlap_lengths(a, b, self.obstacles)

    def _evaluate_parts(self, X: np.ndarray) -> dict[str, np.ndarray]:
        """Every term of `evaluate`, the readable numpy way, for (n, dim) X; a row with a
        non-finite entry gets f = phi = inf (`evaluate`), its other terms as computed (NaN)."""
        X = np.atleast_2d(X)
        pts, times, active = self._split(X)
        a, b = self._legs(pts, active)
        seg = b - a
        dist = np.hypot(seg[..., 0], seg[..., 1])
        leg_times = self.model.flight_time(dist)
        t_fly = leg_times.sum(axis=1)
        hov = np.where(active, times, 0.0)
        t_hover = hov.sum(axis=1)
        f = self.alpha * t_fly + (1.0 - self.alpha) * t_hover
        # each plan's (I, J) rates by the compiled range-cut kernel (the same array as the
        # (n, I, J) numpy broadcast: `formulas.link_rates`), O(I x sensors in range) a plan;
        # a plan with a non-finite point keeps numpy's broadcast (NaN stays NaN)
        R = (np.stack([self.rates(q) for q in pts]) if len(pts) and np.isfinite(pts).all()
             else self.rates(pts)) * active[:, :, None]
        if self.scheduled:  # no C3; the most data the hover times can take (a max flow)
            v3_each = np.zeros(R.shape[:2])
            Q = np.stack([scheduled_flow(R[s][active[s]], hov[s][active[s]], self.required,
                                         self.bandwidth) for s in range(len(R))])  # fmt: skip
        else:
            v3_each = np.maximum(R.sum(axis=2) - self.bandwidth, 0.0)
            Q = np.matmul(hov[:, None, :], R)[:, 0, :]
        v4_each = np.maximum(self.required - Q, 0.0)
        l_vio = self._overlap(a, b).sum(axis=1)
        v5 = collision_penalty(l_vio, self.mu, self.nu)
        v3 = v3_each.sum(axis=1)
        v4 = v4_each.sum(axis=1)
        v6 = self._excess_hover(X)
        phi = v3 + v4 + v5 + v6
        bad = ~np.isfinite(X).all(axis=1)
        if bad.any():  # not a plan: never feasible (`evaluate`)
            f = np.where(bad, np.inf, f)
            phi = np.where(bad, np.inf, phi)
        return {
            "f": f, "phi": phi, "t_fly": t_fly, "t_hover": t_hover, "l_vio": l_vio,
            "v3": v3, "v4": v4, "v5": v5, "v6": v6, "v3_each": v3_each, "v4_each": v4_each,
            "collected": Q, "leg_times": leg_times, "leg_lengths": dist,
            "active": active, "points": pts, "times": times,
        }  # fmt: skip

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Objective f and total violation phi for a population X of shape (n, dim).

        The compiled fast path (`planner_core.model.kernels`, then the obstacle kernel on all
        n (I_max + 1) legs in one batch); `_evaluate_parts` is its numpy twin. Cost: O(n I_max
        x sensors in range) for the terms plus the legs' obstacle tests, and one O(n dim)
        finiteness check.

        A row with a non-finite entry (NaN, +-inf: an optimiser's arithmetic gone wrong) is
        not a plan: its f and phi are inf, so it is never feasible and loses to every plan under
        Deb's rule and the penalised score (NaN gave f = nan, phi = 0: "feasible"); the kernels
        see the lower bound in its place, never a NaN. `breakdown` says the same.

        Args:
            X: (n, dim) decision vectors, or one (dim,) vector (read as n = 1).

        Returns:
            (f (n,) s, phi (n,) >= 0: v3 + v4 + v5, plus v6 with corner slots; both inf for a
            row with a non-finite entry).

        Raises:
            ValueError: X not of shape (n, dim).
        """
        X = np.ascontiguousarray(np.atleast_2d(X), dtype=float)
        if X.ndim != 2 or X.shape[1] != self.dim:
            raise ValueError(f"X: expected shape (n, {self.dim}), got {X.shape}")
        bad = None
        if not np.isfinite(X.sum()):  # a finite sum: every entry finite (one pass, no mask)
            finite = np.isfinite(X).all(axis=1)  # or finite entries whose sum overflowed
            if not finite.all():  # the kernels get a plan in the box; the rows set below
                bad = ~finite
                X = np.where(bad[:, None], self.lower, X)
        n = X.shape[0]
        legs = self.n_points + 1
        A = np.empty((n, legs, 2))
        B = np.empty((n, legs, 2))
        f = np.empty(n)
        v3 = np.empty(n)
        v4 = np.empty(n)
        model_terms(
            X, self.n_points, self.variable_length, self.tau, self.upper, self.start, self.end,
            self.sensors, self.required, self.altitude, self.peak_rate, self.decay,
            *self.model.window, self.bandwidth, self.v_max, self.accel, self.alpha, A, B, f,
            v3, v4, self.scheduled,
        )  # fmt: skip
        # the legs as one (n (I_max + 1), 2) batch: the kernel's fast call, no broadcasting
        l_vio = self._overlap(A.reshape(-1, 2), B.reshape(-1, 2)).reshape(n, legs).sum(axis=1)
        v5 = collision_penalty(l_vio, self.mu, self.nu)
        phi = v3 + v4 + v5
        if self.corner_slots:
            phi = phi + self._excess_hover(X)
        if bad is not None:
            f[bad] = np.inf
            phi[bad] = np.inf
        return f, phi

    def breakdown(self, x: np.ndarray) -> dict[str, Any]:
        """Every term of the model for one solution, as plain Python values (JSON-ready).

        Args:
            x: (dim,) one decision vector.

        Returns:
            f, phi, score, t_fly, t_hover (s), l_vio (m), v3, v4, v5, n_hover, the active
            hover points (m) and times (s), leg times (s) and lengths (m), v3 per point, and
            per sensor id the data collected, required and short (Mbit); with corner slots
            also v6 and n_corner (active points of 0 s). A vector with a non-finite entry has
            f = phi = score = inf, as `evaluate` gives it (its other terms may be NaN).
        """
        p = self._evaluate_parts(np.asarray(x, dtype=float)[None, :])
        act = p["active"][0]
        hp = p["points"][0][act]
        ht = p["times"][0][act]
        n_legs = int(act.sum()) + 1
        return {
            "f": float(p["f"][0]),
            "phi": float(p["phi"][0]),
            "score": float(penalised_score(p["f"][0], p["phi"][0])),
            "t_fly": float(p["t_fly"][0]),
            "t_hover": float(p["t_hover"][0]),
            "l_vio": float(p["l_vio"][0]),
            "v3": float(p["v3"][0]),
            "v4": float(p["v4"][0]),
            "v5": float(p["v5"][0]),
            "n_hover": int(act.sum()),
            "hover_points": hp.tolist(),
            "hover_times": ht.tolist(),
            "leg_times": p["leg_times"][0][:n_legs].tolist(),
            "leg_lengths": p["leg_lengths"][0][:n_legs].tolist(),
            "v3_per_point": p["v3_each"][0][act].tolist(),
            "collected": dict(zip(self.map.sensor_ids, p["collected"][0].tolist(), strict=True)),
            "required": dict(zip(self.map.sensor_ids, self.required.tolist(), strict=True)),
            "shortfall": dict(zip(self.map.sensor_ids, p["v4_each"][0].tolist(), strict=True)),
        } | ({"v6": float(p["v6"][0]), "n_corner": int((act & (p["times"][0] == 0.0)).sum())}
             if self.corner_slots else {})  # fmt: skip

    # ------------------------------------------------------------------ initial population
    def initial_population(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """n starting solutions: the first half obstacle-aware sensor routes, the rest uniform.

        A sensor-aware start (`planner_core.model.seeding`) clusters the sensors, visits the cluster
        centres in a short order, routes blocked legs around obstacles through a visibility
        graph and hovers long enough to serve every sensor, so most starts are feasible.
        Uniform ones keep the population diverse. The DE uses this hook when a problem has it
        (synthetic problems do not), and its draws come from the DE's own seeded generator.

        Args:
            rng: the DE's generator; every draw comes from it.
            n: population size.

        Returns:
            (n, dim): rows 0 .. n // 2 - 1 seeded (`Seeder.solution`), the rest uniform in
            [lower, upper].
        """
        span = self.upper - self.lower
        X = self.lower + rng.random((n, self.dim)) * span
        for s in range(n // 2):
            X[s] = self._clustered_solution(rng)
        return X

    @cached_property
    def seeder(self) -> Seeder:
        """This problem's `planner_core.model.seeding.Seeder` (visibility graph, reach), built on
        first
        use and kept: the sensor-aware starts, the memetic repair and the engineering peer share
        it.

        Returns:
            The Seeder (`Seeder.for_problem`), the same object on every call.
        """
        return Seeder.for_problem(self)

    @cached_property
    def uniform_layout(self) -> bool:
        """Whether the sensors lie uniformly over the area: their Clark-Evans ratio
        (`planner_core.model.layout.clark_evans`) at least `layout.UNIFORM_LAYOUT`; False for
        clustered fields and corridors. Computed once (O(J log J)) and kept.

        Returns:
            True for a uniform layout.
        """
        from planner_core.model.layout import UNIFORM_LAYOUT, clark_evans

        return bool(clark_evans(self.model.sensors, self.map.width * self.map.height)
                    >= UNIFORM_LAYOUT)

    def _clustered_solution(self, rng: np.random.Generator) -> np.ndarray:
        """One obstacle-aware sensor-serving start (the problem's seeder)."""
        return self.seeder.solution(rng)

    # ------------------------------------------------------------------ encoding
    def encode(self, hover_points: np.ndarray, hover_times: np.ndarray) -> np.ndarray:
        """A decision vector whose decoded plan is exactly these hover points and times.

        Args:
            hover_points: (k, 2) hover points, m, in flying order.
            hover_times: (k,) hover times, s.

        Returns:
            (dim,) vector: the k points first with eps 1, the other slots at the end point with
            t = 0 and eps = 0.

        Raises:
            ValueError: hover_times not one value per hover point; k > n_points; k !=
                n_points in fixed-length mode; k < n_points with activation_threshold 0 in
                variable-length mode.
        """
        hp = np.asarray(hover_points, dtype=float).reshape(-1, 2)
        ht = np.asarray(hover_times, dtype=float).reshape(-1)
        k = len(hp)
        if len(ht) != k:  # numpy would broadcast a single time to every point
            raise ValueError(f"hover_times: {counted(len(ht), 'value')} for "
                             f"{counted(k, 'hover point')}; give one per point")
        if k > self.n_points:
            slots = self.n_points - self.hover_limit
            raise ValueError(f"{counted(k, 'hover point')} exceed I_max = {self.hover_limit}"
                             + (f" + {counted(slots, 'corner slot')}" if slots else ""))
        if not self.variable_length and k != self.n_points:
            raise ValueError(f"fixed-length mode needs exactly {self.n_points} hover points")
        x = np.zeros((self.n_points, 4))
        x[:k, :2] = hp
        x[:k, 2] = ht
        x[:k, 3] = 1.0
        # inactive slots: placed at the end point, zero hover time, eps = 0 (< tau unless tau = 0)
        x[k:, :2] = self.end
        if self.variable_length and self.tau <= 0.0 and k < self.n_points:
            raise ValueError("with activation_threshold 0 every slot is active; give I_max points")
        return x.reshape(-1)

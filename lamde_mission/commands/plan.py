"""`lamde-mission plan MAP -o OUT`: optimise, verify in the sim, write the mission file."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from collections.abc import Callable
from typing import Any

from planner_core import defaults as D


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `lamde-mission plan` (options, help).

    Args:
        sub: the subcommands of `lamde_mission.cli.build_parser`.

    Returns:
        The command's parser (`build_parser` sets `run` as its `_run`).
    """
    p = sub.add_parser(
        "plan",
        help="plan a mission for a map and write it as .plan, .waypoints or .geojson",
        description="Optimise hover points and hover times for MAP with LAMDE's variable-length "
        "DE, replay the mission in the simulator, print a summary and write the mission file. "
        "An infeasible mission is not written unless --allow-infeasible. Exit status: 0 ok, "
        "1 infeasible, 2 bad input. A map with a battery (uav.battery or uav.endurance_s) or a "
        "fleet is planned as sorties (docs/sorties.md): OUT is then a directory (new, empty or an "
        "earlier sortie directory: it is replaced whole), written whole or not at all, holding "
        "mission-v{vehicle}-s{sortie}.plan (both 1-based: "
        "mission-v1-s2.plan is vehicle 1's second sortie, each a complete mission from "
        "take-off at its depot to landing at its depot) and fleet.json (per sortie: depots, "
        "duration, energy, energy left above the reserve, sensors it takes data from; per vehicle: "
        "makespan).",
    )
    p.add_argument("map", help="map file (JSON)")
    from lamde_mission.commands._common import add_origin_option

    add_origin_option(p)
    p.add_argument("-o", "--output", required=True, metavar="OUT",
                   help="mission file to write (.plan, .waypoints or .geojson); for a map with "
                   "a battery or fleet, the sortie directory DIR/ (mission-v1-s1.plan, ..., "
                   "fleet.json)")
    p.add_argument("--objective", choices=D.GOALS, default=None,
                   help="maps with a battery or fleet: minimise the total (the paper's f "
                   "summed over sorties + swap_s per battery swap) or the makespan (the "
                   "longest vehicle's time); default the map's objective.goal")
    p.add_argument("--sortie-budget", type=int, default=None, metavar="N",
                   help="maps with a battery or fleet: evaluations of each pipeline run on one "
                   "sortie's or depot's sensors (default 2,000; from the population to "
                   f"{D.MAX_BUDGET:,})")
    p.add_argument("--rounds", type=int, default=None, metavar="N",
                   help="maps with a battery or fleet: improving rounds of the sortie planner "
                   "at most (default 3; 0: the better of its two starts)")
    p.add_argument("--format", choices=("plan", "waypoints", "geojson"),
                   help="output format (default: from OUT's suffix): for an OUT without "
                   "one of the suffixes .plan, .waypoints, .geojson (e.g. mission.txt); one "
                   "that disagrees with OUT's suffix is refused (a .plan file holding QGC WPL "
                   "text would not open in QGroundControl)")
    p.add_argument("--seed", type=int, default=D.SEED,
                   help=f"random seed (same seed, same plan; default {D.SEED})")
    p.add_argument("--budget", type=int, default=D.BUDGET,
                   help=f"evaluations in all stages (default {D.BUDGET:,}; from the "
                   f"population to {D.MAX_BUDGET:,}); what the default pipeline does not "
                   "need for its fixed stages goes to the improving rounds, so a larger budget "
                   "buys a better plan")
    p.add_argument("--time-limit", type=float, metavar="SECONDS",
                   help="stop the improving stages after SECONDS and write the best plan found "
                   "(the one-time kernel compile and the setup, reading the map and building "
                   "its visibility graph, are not counted: the search needs them; at the "
                   "obstacle limit setup takes minutes, docs/planning.md; default: none, the "
                   "budget alone ends the run). Combine with a large --budget to plan for a "
                   "deadline; a time limit trades the same-seed-same-plan guarantee for the "
                   "deadline")
    p.add_argument("--population", type=int, default=D.POPULATION,
                   help=f"DE population (default {D.POPULATION}; {D.MIN_POPULATION} to "
                        f"{D.MAX_POPULATION:,})")
    p.add_argument("--configurator", choices=D.CONFIGURATORS, default=D.CONFIGURATOR,
                   help="how DE operators and F/Cr are chosen each generation "
                   f"(default {D.CONFIGURATOR})")
    p.add_argument("--scheduler", default="default", metavar="NAME",
                   help="how the improving stage chooses its macro-actions (kicks, structural "
                   "search, restarts, fresh sweeps, DE blocks): default (today's rounds), a "
                   "static schedule, lamde-s (the learned selector of a schedule and of the "
                   "DE's share of the budget, within 1.5x the default's CPU on average) or "
                   "lamde-s-ppo (the policy trained by PPO); lamde-s-ppo:DIR or lamde-s:DIR "
                   "for a checkpoint of your own (docs/scheduler.md lists them)")
    p.add_argument("--corner-slots", default="auto", metavar="auto|K",
                   help="detour corners (points of 0 s, written as NAV_WAYPOINT) do not count "
                   "against I_max: K extra slots for them, at most I_max hover points stay "
                   "feasible (docs/missions.md). Default auto: K from the map, the blocked "
                   "legs left in the seeder's plans when I_max slots cannot hold their "
                   "corners (0 on the paper's suite maps, 3 on campus-500; docs/scaling.md). "
                   "0: the paper's model, every point takes one of the I_max slots. At most "
                   f"{D.MAX_CORNER_SLOTS} (what auto can ask for at I_max 200). A map "
                   "with a battery or fleet (sorties) plans with 0")
    p.add_argument("--policy", metavar="CHECKPOINT",
                   help="with --configurator lamde: a checkpoint folder from `lamde-mission "
                   "train` instead of the shipped lamde-v2")
    p.add_argument("--init", choices=D.INIT_MODES, default=D.INIT,
                   help="initial population: seeded (sensor-aware starts) or uniform in the "
                   f"box (the paper's protocol); default {D.INIT}")
    p.add_argument("--memetic", choices=D.MEMETIC_MODES, default=D.MEMETIC,
                   help="memetic step on the elite (2-opt, LP hover times, removals, repair of "
                   "unserved sensors and blocked legs): auto = on with --init uniform, off with "
                   f"seeded; default {D.MEMETIC}")
    p.add_argument("--starts", type=int, default=D.STARTS, metavar="N",
                   help="constructive plans (greedy set covers, k-means sweep, open-path "
                   "order, visibility-graph detours, LP hover times) put into the initial "
                   f"population, the best of the first {D.START_CANDIDATES} built; 0: none; "
                   f"default {D.STARTS}")
    p.add_argument("--no-descent", action="store_true",
                   help="skip the hover-point descent with exact LP hover times on the best "
                   f"{D.DESCENTS} constructive and seeder plans and on the final plan")
    p.add_argument("--fixed-length", action="store_true",
                   help="use all I_max hover points (the paper's LAMDE-F ablation)")
    p.add_argument("--no-polish", action="store_true",
                   help="skip the hover-time LP polish and the final plan's descent")
    p.add_argument("--finish", choices=("land", "rtl"), default="land",
                   help="end the mission by landing at the end point or returning to launch "
                   "(rtl: refused up front when the straight leg back to the start crosses an "
                   "obstacle, which the planner does not route around)")
    p.add_argument("--autopilot", choices=("px4", "ardupilot", "generic"), default="generic",
                   help="write what this autopilot stores: lat/lon on the 1e-7 degree grid, "
                   "float32 parameters, hover times in whole seconds (rounded up) for ardupilot "
                   "and generic (a file either autopilot stores unchanged; default), float32 for "
                   "px4. The summary and exit status are those of the stored mission")
    p.add_argument("--plot", metavar="PNG", help="also draw the mission (.png or .svg); for a "
                   "sortie directory every sortie, a colour per vehicle, a line style per "
                   "sortie, depots and battery swaps marked (as `show MAP DIR/`), written "
                   "beside DIR, never inside it (DIR is replaced whole)")
    p.add_argument("--report", metavar="JSON", help="also write the plan and verdicts as JSON")
    p.add_argument("--allow-infeasible", action="store_true",
                   help="write the mission even if constraints are violated (exit status 1)")
    p.add_argument("--mkdir", action="store_true",
                   help="create missing folders of the output paths (otherwise exit 2)")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no summary")
    p.add_argument("--verbose", action="store_true",
                   help=f"the summary lists every sensor's data (by default, past "
                   f"{SENSOR_LINES} sensors, the {SENSORS_SHOWN} least served and every short "
                   "one; --report holds them all)")
    return p


class _StatusLine:
    """One status line on a stream (stderr), shared by the plan's progress bar and its setup
    lines: on a TTY one line rewritten in place, "\\r" and the line padded to the widest
    written so far (a shorter line leaves nothing of a longer one), at most every `every`
    seconds unless forced; off a TTY a line of its own, once past each `step` of the way
    (short of 1.0) or when forced. `end` ends an open TTY line. The caller formats the line
    and reads its own clock (`now`, any clock, the same for every call)."""

    def __init__(self, stream: Any = None, every: float = 0.1, step: float = 0.25,
                 tty: Callable[[], bool] | None = None) -> None:
        """Args:
            stream: the text stream; None: the sys.stderr of each write (a default bound at
                import would keep a stream that a caller, or pytest's capture, has since
                replaced and closed).
            every: the least seconds between two TTY lines that are not forced.
            step: off a TTY, a line once past each multiple of `step` (a fraction).
            tty: a callable telling whether the stream is a terminal; None: its isatty.
        """
        self.stream = stream
        self.every = every
        self.step = step
        self._is_tty = tty
        self.last = -math.inf  # when a line was last written (the caller's clock)
        self.next_step = step  # off a TTY: the next fraction that gets a line
        self.wide = 0  # the widest TTY line written since the last end
        self.open = False  # a TTY line is written and not yet ended

    @property
    def out(self) -> Any:
        """The stream written to now."""
        return sys.stderr if self.stream is None else self.stream

    def tty(self) -> bool:
        """Whether the stream is a terminal (the line is rewritten in place)."""
        if self._is_tty is not None:
            return bool(self._is_tty())
        return bool(getattr(self.out, "isatty", lambda: False)())

    def due(self, frac: float, now: float, force: bool = False) -> bool:
        """Whether a line `frac` of the way, at time `now`, is to be written: forced, or on a
        TTY `every` s after the last, or off one once past the next step short of 1.0."""
        if force:
            return True
        if self.tty():
            return now - self.last >= self.every
        return self.next_step <= frac < 1.0

    def write(self, line: str, frac: float, now: float) -> None:
        """Write `line` (`frac` of the way, at time `now`), due or not: in place on a TTY, on
        its own line otherwise; the steps up to `frac` are passed."""
        out = self.out
        if self.tty():
            out.write("\r" + line.ljust(self.wide))
            self.wide = max(self.wide, len(line))
            self.open = True
        else:
            out.write(line + "\n")
        self.last = now
        while self.next_step <= frac:
            self.next_step += self.step
        out.flush()

    def show(self, line: str, frac: float, now: float, force: bool = False) -> bool:
        """`write` the line if it is `due`; whether it was."""
        if not self.due(frac, now, force):
            return False
        self.write(line, frac, now)
        return True

    def end(self, final: str | None = None) -> None:
        """End the line and start afresh (no line written yet, the first step next): `final`
        on a line of its own (on a TTY over the open line, padded over it), else only a
        newline after an open TTY line (idempotent)."""
        out = self.out
        if final is not None:
            out.write(("\r" + final.ljust(self.wide) if self.open else final) + "\n")
            out.flush()
        elif self.open:
            out.write("\n")
            out.flush()
        self.wide = 0
        self.open = False
        self.last = -math.inf
        self.next_step = self.step


class _ProgressBar:
    """The stage running and the budget spent: one updating line on stderr (a TTY), or a line
    per stage and per quarter of the budget otherwise; `close` ends the line, so what is
    printed next starts on its own (`_StatusLine`)."""

    #: seconds between two lines of a long stage's own progress (`Progress.detail`) off a TTY
    DETAIL_EVERY = 5.0

    def __init__(self, stream: Any = None, width: int = 24):
        # None: the sys.stderr of the moment (a default bound at import would keep a stream
        # that a caller, or pytest's capture, has since replaced and closed)
        stream = sys.stderr if stream is None else stream
        self.line = _StatusLine(stream, every=0.1, step=0.25)
        self.width = width
        self.stage = ""

    def __call__(self, p: Any) -> None:
        frac = p.evaluations / max(p.budget, 1)
        done = frac >= 1.0
        now = time.monotonic()
        new_stage = p.stage != self.stage
        self.stage = p.stage
        detail = getattr(p, "detail", "")
        if detail and not self.line.tty():  # a long stage between evaluations: a line every
            if now - self.line.last < self.DETAIL_EVERY:  # DETAIL_EVERY s at most
                return
        elif not self.line.due(frac, now, force=done or new_stage):
            return
        fill = int(round(frac * self.width))
        bar = "#" * fill + "." * (self.width - fill)
        if p.best_f == float("inf") and p.best_phi == float("inf"):
            best = "no plan scored yet"
        else:
            state = "feasible" if p.best_phi == 0 else "infeasible"
            best = f"best f {p.best_f:10.2f}  phi {p.best_phi:10.4g}  {state}"
        line = f"{p.stage:<15} [{bar}] {p.evaluations}/{p.budget} evals  {best}"
        if detail:
            line += f"  ({detail})"
        self.line.write(line, frac, now)

    def close(self) -> None:
        """End an open TTY line (idempotent)."""
        self.line.end()


def _stage_table(plan: Any) -> list[str]:
    """The summary's per-stage lines: evaluations, seconds and the incumbent's f before and
    after each stage that ran."""
    if not plan.stages:
        return []

    def fmt(f: float, phi: float) -> str:
        if f != f or f == float("inf"):
            return "-"
        return f"{f:.2f}" if phi == 0 else f"{f:.2f} (phi {phi:.3g})"

    out = ["  stages          evaluations   seconds   f before -> after"]
    for s in plan.stages:
        stop = f"  [{s.stopped}]" if s.stopped else ""
        out.append(f"    {s.name:<15} {s.evaluations:>8}  {s.seconds:8.3f}   "
                   f"{fmt(s.f_before, s.phi_before)} -> {fmt(s.f_after, s.phi_after)}{stop}")
    return out


def _run_settings(config: dict[str, Any]) -> str:
    """The summary's words for a plan's scheduler and budget split, from its recorded
    `config`: ", scheduler lamde-s -> default, DE share 0.4", ", DE share 0" (a split other
    than the default `de_share`: the default's own beyond 160 sensors or up to 120 with the
    large rounds, a learned one's, a caller's) or "" (the default scheduler at the default
    split)."""
    sched = config.get("scheduler")
    choice = config.get("scheduler_choice")
    share = config.get("de_share")
    share = (f", DE share {share:g}" if isinstance(share, float) and share != D.DE_SHARE
             else "")
    if not sched:
        return share
    return f", scheduler {sched}" + (f" -> {choice}" if choice else "") + share


#: the summary lists every sensor's data up to this many sensors (the paper's maps, 40 at most)
SENSOR_LINES = 40
#: past SENSOR_LINES sensors (without --verbose), the least served this many are listed, and
#: every short one; the rest are counted in one line
SENSORS_SHOWN = 10


def _sensor_rows(m: Any, timeline: Any) -> list[dict[str, Any]]:
    """Each sensor's data as the simulator replayed it: id, collected and required Mbit,
    whether it is served (C4), in map order; what `--report`'s "sensors" holds. O(J)."""
    req = dict(zip(m.sensor_ids, m.required_data.tolist(), strict=True))
    got = timeline.totals.collected
    return [{"id": sid, "collected": float(got[sid]), "required": float(req[sid]),
             "ok": bool(got[sid] >= req[sid])} for sid in m.sensor_ids]  # fmt: skip


def _sensor_lines(rows: list[dict[str, Any]], *, every: bool = False) -> list[str]:
    """The summary's data lines: every sensor up to SENSOR_LINES (or `every`), else the
    SENSORS_SHOWN least served (lowest collected / required) and every short one, least
    served first, and one line counting the rest. O(J log J).

    Args:
        rows: `_sensor_rows`.
        every: list every sensor whatever the count (`--verbose`).

    Returns:
        The lines, header first.
    """
    from planner_core.textio import counted, printable

    def ratio(r: dict[str, Any]) -> float:
        return r["collected"] / r["required"] if r["required"] > 0 else float("inf")

    def line(r: dict[str, Any]) -> str:
        ok = "ok" if r["ok"] else "SHORT"
        over = f"{100 * (ratio(r) - 1):+.2f} %" if r["required"] > 0 else ""
        return (f"    {printable(r['id']):<12} {r['collected']:10.1f} / {r['required']:<8.1f} "
                f"{ok:<5} {over}")

    if every or len(rows) <= SENSOR_LINES:
        return ["  data collected vs required (Mbit):", *(line(r) for r in rows)]
    order = sorted(range(len(rows)), key=lambda k: (ratio(rows[k]), k))
    shown = [k for n, k in enumerate(order) if n < SENSORS_SHOWN or not rows[k]["ok"]]
    listed = set(shown)
    rest = [rows[k] for k in order if k not in listed]
    out = [f"  data collected vs required (Mbit), the {len(shown)} least served of "
           f"{counted(len(rows), 'sensor')}:", *(line(rows[k]) for k in shown)]
    if rest:  # sorted: the first is the least served of them
        margin = (f"the least {100 * (ratio(rest[0]) - 1):+.2f} % above its requirement"
                  if rest[0]["required"] > 0 else "none required")
        out.append(f"    ... and {len(rest)} more, all ok ({margin}); every sensor: --verbose, "
                   "or --report's \"sensors\"")
    return out


def _summary(
    plan: Any, m: Any, timeline: Any, verdicts: Any, out: str | list[str] | None,
    stored: Any = None, *, every_sensor: bool = False,
) -> str:
    from lamde_mission.commands._common import clearance_words
    from planner_core.textio import counted, printable

    b = plan.breakdown
    t = timeline.totals
    who = "stored" if stored is not None else "sim"
    t_compile = plan.timings.get("compile", 0.0)
    compiling = f"; {t_compile:.1f} s compiling (or loading) the kernels" if t_compile > 0.05 \
        else ""
    stopped = f", stopped by the {plan.stopped}" if plan.stopped else ""
    sched = _run_settings(plan.config)
    # a point of 0 s is written as a corner (NAV_WAYPOINT, flown through), not a hover point
    times = (stored if stored is not None else plan).hover_times
    n_corner = sum(1 for t in times if float(t) == 0.0)
    # corner slots (issue 31): K slots beyond I_max that only corners may use
    k_slots = int(plan.config.get("corner_slots", 0))
    slots = (f"{counted(k_slots, 'corner slot')} beyond I_max"
             + (", auto" if plan.config.get("corner_slots_rule") == "auto" else "")
             if k_slots else "")  # fmt: skip
    corners = (f" + {counted(n_corner, 'corner')} (0 s, NAV_WAYPOINT"
               + (f"; {slots})" if slots else ")") if n_corner
               else f" ({slots})" if slots else "")  # fmt: skip
    lines = [
        f"map '{printable(m.name)}': {counted(plan.n_hover - n_corner, 'hover point')}{corners}, "
        f"{plan.evaluations} evaluations, "
        f"{plan.timings.get('planning', plan.wall_time - t_compile):.2f} s planning (seed "
        f"{plan.seed}, {plan.configurator}{sched}{stopped})" + compiling,
        f"  flight time   {b['t_fly']:10.2f} s    ({who} {t.t_fly:.2f} s)",
        f"  hover time    {b['t_hover']:10.2f} s    ({who} {t.t_hover:.2f} s)",
        f"  f             {plan.f:10.2f}      ({who} {t.f:.2f}; alpha {m.spec.objective.alpha:g})",
        f"  phi           {plan.phi:10.4g}",
    ]
    if stored is not None:
        lines.append(
            f"  stored as     {stored.dialect.name}: points moved <= "
            f"{float(stored.moved_m.max(initial=0.0)) * 100:.2f} cm onto the 1e-7 degree grid, "
            f"hover times +{float(stored.added_s.sum()):.3g} s in all"
        )
    if plan.polish is not None:
        pol = plan.polish
        lines.append(f"  polish        f {pol['f_before']:.2f} -> {pol['f_after']:.2f}, "
                     f"phi {pol['phi_before']:.4g} -> {pol['phi_after']:.4g}"
                     + ("" if pol["accepted"] else " (kept the unpolished plan)"))
    lines.extend(_stage_table(plan))
    lines.extend(_sensor_lines(_sensor_rows(m, timeline), every=every_sensor))
    sf = m.spec.safety
    kept = clearance_words(verdicts.clearance, ".2f")
    lines.append(f"  safety: clearance {kept} (asked {sf.clearance:g} m), "
                 f"data margin asked {100 * sf.data_margin:g} %")
    lines.append("  constraints (simulator) of the stored mission:" if stored is not None
                 else "  constraints (simulator):")
    lines.extend("    " + printable(row) for row in verdicts.table().splitlines())
    if out:  # every file written: the mission, then the plot and report when asked
        paths = [out] if isinstance(out, str) else out
        lines.extend(f"wrote {printable(path)}" for path in paths)
    return "\n".join(lines)


def _violations(plan: Any, verdicts: Any) -> list[str]:
    from planner_core.textio import printable

    b = plan.breakdown
    out = []
    if b["v3"] > 0:
        out.append(f"C3 bandwidth exceeded by {b['v3']:.4g} Mbit/s in total")
    for sid, short in b["shortfall"].items():
        if short > 0:
            out.append(f"C4 sensor '{printable(sid)}' short by {short:.4g} Mbit")
    if b["l_vio"] > 0:
        out.append(f"C5 path runs {b['l_vio']:.4g} m inside obstacles")
    for v in verdicts:
        if not v.passed:
            out.append(printable(f"sim {v.name} {v.title}: FAIL, margin {v.margin:.4g} {v.unit}; "
                                 f"{v.detail}"))
    if plan.polish and plan.polish.get("unserved"):
        out.extend(printable(u) for u in plan.polish["unserved"])
    return out


def _check_return_leg(m: Any) -> None:
    """`--finish rtl`: the vehicle flies straight back from the end point to the launch point,
    a leg the paper's model (start -> hover points -> end) does not plan. Refuse up front, with
    why, when that straight leg crosses an obstacle (inflated by the clearance), since no plan
    could then make the mission safe; otherwise the leg is clear whatever the plan."""
    import numpy as np

    from lamde_mission.errors import UsageError
    from sim.obstacles import obstacle_shapes, overlap_lengths

    pm = m.planning_map()
    shapes = obstacle_shapes(pm)
    if not shapes:
        return
    over = overlap_lengths(np.array([m.end, m.start], dtype=float), shapes)[0]
    # the planning map lists circles, no-fly zones, then the rectangles (as polygons) and
    # the polygons: name each obstacle by the map's own kind and number
    own = obstacle_shapes(m)
    obs = m.spec.obstacles
    nc, nr, nz = len(obs.circles), len(obs.rectangles), len(obs.no_fly_zones)
    order = (list(range(len(own))) if pm is m else
             [*range(nc), *range(nc + nr, nc + nr + nz), *range(nc, nc + nr),
              *range(nc + nr + nz, len(own))])
    hit = [own[order[k]].label for k in np.flatnonzero(over > 1e-9)]
    if hit:
        raise UsageError(
            "--finish rtl: RETURN_TO_LAUNCH flies straight from the end point back to the start, "
            f"and that leg crosses {', '.join(hit[:4])}{' ...' if len(hit) > 4 else ''} "
            f"(with the {m.spec.safety.clearance:g} m clearance); the planner plans start -> "
            "hover points -> end only, so use --finish land (or move the end point)"
        )


def _peek_map(path: str) -> Any:
    """The map at `path`, loaded once to choose the path (sorties when it gives a battery or a
    fleet) and handed on to it (`load_map_or_fail(loaded=)`; a 2,000-footprint campus takes
    2.5 s to load); None when it does not load (the single-flight path then reports why)."""
    from planner_core.model.mapio import MapError, load_map

    try:
        return load_map(path)
    except (MapError, TypeError, ValueError, OSError):
        return None


def _sortie_lines(check: Any, m: Any) -> list[str]:
    """Per sortie: depots, duration, energy, what is left above the reserve, sensors served;
    per vehicle its makespan; then the plan's totals (the sim's figures on the stored
    missions)."""
    from lamde_mission.commands._common import fleet_makespan_words
    from lamde_mission.sorties import pad_words
    from planner_core.textio import counted

    lines = []
    for v, ss in check.vehicles().items():
        for k, s in enumerate(ss):
            vd = s.verdicts
            energy = (f"energy {vd.energy_wh:7.2f} Wh of {vd.usable_wh:.2f} usable, "
                      f"{vd.above_reserve_wh:6.2f} Wh left above the reserve") \
                if vd.energy_wh is not None else "no battery"
            lines.append(f"  {s.file:<18} {pad_words(m, s.depot_start, s.takeoff_xy)} -> "
                         f"{pad_words(m, s.depot_end, s.landing_xy)}: take-off "
                         f"+{check.takeoff(v, k + 1):.0f} "
                         f"s, {s.duration_s:8.1f} s, {energy}, "
                         f"data from {counted(len(s.sensors), 'sensor')}")
        launch = f"launch at +{check.launch(v):.0f} s, " if len(check.launches) > 1 else ""
        lines.append(f"  vehicle {v}: {launch}{counted(len(ss), 'sortie')}, makespan "
                     f"{check.makespan(v):.1f} s")
    lines.append(f"  total {check.total_s:.1f} s over {counted(len(check.sorties), 'sortie')} "
                 f"with {counted(check.swaps, 'battery swap')}; f summed + swaps "
                 f"{check.f_total:.2f}" + fleet_makespan_words(check))
    for v in check.combined:
        lines.append(f"  whole plan {v.name}: {'PASS' if v.passed else 'FAIL'} ({v.detail})")
    for v in check.fleet:
        if v.name in ("SEPARATION", "LINKS", "TIMING") and len(check.launches) > 1:
            lines.append(f"  fleet {v.name}: {'PASS' if v.passed else 'FAIL'} ({v.detail})")
    return lines


def _run_sorties(args: argparse.Namespace, loaded: Any = None) -> int:
    """`plan` for a map with a battery or fleet: sorties written as a directory."""
    from pathlib import Path

    from lamde_mission.commands._common import load_map_or_fail, with_origin_or_fail
    from lamde_mission.errors import UsageError
    from planner_core.textio import counted, printable

    for opt, bad, why in (
        ("--format", args.format not in (None, "plan"),
         "its sorties are written as .plan files in a directory"),
        ("--report", args.report, "the sortie directory's fleet.json is its report"),
        ("--finish", args.finish != "land", "every sortie lands at its depot"),
        ("--policy", args.policy, "the sortie planner's pipeline runs take no policy file"),
        ("--time-limit", args.time_limit is not None,
         "the sortie planner runs to its budgets: --budget and --sortie-budget"),
        ("--scheduler", args.scheduler != "default",
         "the sortie planner's pipeline runs keep the default improving rounds"),
        ("--corner-slots", _corner_slots(args) not in ("auto", 0),
         "the sortie planner does not take corner slots yet"),
    ):
        if bad:
            raise UsageError(f"{opt}: not available for a map with a battery or fleet ({why})")
    from lamde_mission.sorties import output_in_sortie_dir, sortie_dir_refusal

    if args.plot:  # before any work (nothing written, no folder made), as for one flight
        if not args.plot.lower().endswith((".png", ".svg")):
            raise UsageError(f"--plot: {args.plot}: image format must be PNG or SVG "
                             "(.png or .svg)")  # fmt: skip
        inside = output_in_sortie_dir(args.plot, args.output)
        if inside is not None:
            raise UsageError(f"--plot: {inside}")
        from lamde_mission.commands._common import check_outputs

        check_outputs([("--plot", args.plot)], mkdir=args.mkdir, inputs=[("map", args.map)])

    out = Path(args.output)
    refusal = sortie_dir_refusal(out)  # before any work: writing replaces the folder whole
    if refusal is not None:
        raise UsageError(f"-o/--output: {printable(args.output)} {refusal}")
    from lamde_mission.commands._common import check_output_folder

    # filled beside itself and renamed onto OUT: its parent must take new entries
    check_output_folder("-o/--output", out, mkdir=args.mkdir, whole=True)
    try:
        D.check_run_args(population=args.population, budget=args.budget, starts=args.starts)
        if args.sortie_budget is not None:
            D.check_budget(args.sortie_budget, args.population, "sortie_budget")
        D.check("seed", args.seed)
    except ValueError as exc:
        raise UsageError("--" + str(exc).replace("_", "-", 1)) from None
    m = load_map_or_fail(args.map, loaded=loaded)
    m = with_origin_or_fail(m, args.origin)
    if m.spec.origin is None:
        raise UsageError(f"{args.map}: origin: the map has no origin (WGS84 position of (0, 0)) "
                         "to write missions with; give --origin LAT,LON[,ALT]")
    from lamde_mission.api import check_fleet_map, plan_fleet
    from lamde_mission.sorties import write_sortie_dir
    from planner_core.fleet.search import SORTIE_BUDGET
    from planner_core.model.mapio import MapError

    try:
        check_fleet_map(m)
    except ValueError as exc:
        raise UsageError(f"{args.map}: {exc}") from None
    from planner_core.pipeline import PlanConfig

    config = PlanConfig(seed=args.seed, budget=args.budget, population=args.population,
                        configurator=args.configurator, init=args.init, memetic=args.memetic,
                        starts=args.starts, descent=not args.no_descent,
                        variable_length=not args.fixed_length, polish=not args.no_polish)
    goal = args.objective or m.goal
    if args.rounds is not None and args.rounds < 0:
        raise UsageError(f"--rounds: must be >= 0, got {args.rounds}")
    status = None
    if not args.quiet:
        print(f"planning sorties for '{printable(m.name)}' (objective {goal}, seed "
              f"{args.seed})...", file=sys.stderr, flush=True)
        status = _StatusLine(every=0.0)
        t0 = time.monotonic()

        def progress(line: str, step: bool = False) -> None:
            # each phase on a line of its own in a log, each move too on a terminal (in place)
            if step and not status.tty():
                return
            status.write(f"  {time.monotonic() - t0:6.1f} s  {line}", 0.0, time.monotonic())
    try:
        result = plan_fleet(m, config=config, goal=goal, sortie_budget=args.sortie_budget,
                            rounds=args.rounds, progress=None if status is None else progress)
    except MapError:
        raise  # bad input (exit 2, one line per problem: `lamde_mission.cli`)
    except ValueError as exc:
        if status is not None:
            status.end()
        print(f"lamde-mission plan: {args.map}: {exc}; nothing written", file=sys.stderr)
        _say_cannot(m, str(exc))
        return 1
    finally:
        if status is not None:
            status.end()
    plan = result.plan
    try:
        check, written = write_sortie_dir(plan, m, out, autopilot=args.autopilot,
                                          allow_infeasible=args.allow_infeasible)
    except FileExistsError as exc:  # the folder changed while planning
        raise UsageError(f"-o/--output: {exc}") from None
    except OSError as exc:  # past the check (disk full, a race): the pending folder is removed
        raise UsageError(f"-o/--output: {printable(str(out))}: cannot write "
                         f"({exc.strerror or exc}); nothing written") from None
    except ValueError as exc:  # more sorties than a sortie directory holds
        print(f"lamde-mission plan: {args.map}: {exc}", file=sys.stderr)
        return 1
    # the sortie planner's runs: more than one where fewer vehicles were tried
    runs = sum(n.startswith("makespan: ") and " fly " in n for n in plan.notes)
    if not args.quiet:
        print(f"map '{printable(m.name)}': {counted(len(plan.sorties), 'sortie')} on "
              f"{counted(len(plan.vehicles), 'vehicle')}, objective {goal}, "
              f"{plan.evaluations:,} evaluations in all: the single flight's "
              f"{args.budget:,} (--budget) and pipeline runs of "
              f"{args.sortie_budget or SORTIE_BUDGET:,} on "
              f"sorties' sensors (--sortie-budget)"
              + (f", over {runs} runs of the sortie planner" if runs > 1 else "")
              + f" (seed {args.seed})")
        # why the plan flies fewer vehicles than the fleet has, when it does
        # (`lamde_mission.api._fewer_vehicles`)
        for note in plan.notes:
            if note.startswith("makespan: "):
                print(f"  {note}")
        print("\n".join(_sortie_lines(check, m)))
        if written:
            print(f"wrote {printable(str(out))}/ ({counted(len(check.sorties), 'mission')} and "
                  "fleet.json)")
    if written and args.plot:  # every sortie as the simulator replays it (`show MAP DIR/`)
        from lamde_mission.commands.show import plot_fleet_dir

        drawn = plot_fleet_dir(m, out, args.plot)
        if not args.quiet:
            print(f"wrote {printable(str(drawn))}")
    if not check.passed:
        print("lamde-mission plan: the sorties are INFEASIBLE"
              + (" (written because of --allow-infeasible):" if written else
                 "; nothing written:"), file=sys.stderr)
        for line in check.failed():
            print(f"  {printable(line)}", file=sys.stderr)
        return 1
    return 0


def _say_cannot(m: Any, said: str = "") -> None:
    """After a failed plan: every line `lamde-mission check` prints as CANNOT for map `m`
    (the fast diagnosis: what no plan can meet), each on its own line on stderr, but those
    `said` holds already; where there is none, the caller's message says what failed."""
    from lamde_mission.commands.check import finding_lines
    from planner_core.model.diagnose import diagnose

    by_lead: dict[str, list[Any]] = {}  # lead -> findings, each lead said once
    for f in diagnose(m).findings:
        if f.fatal and f.message not in said:
            lead = ("the sortie planner cannot plan this map" if f.kind == "SORTIE_LIMIT"
                    else "no plan can meet this map")  # fmt: skip
            by_lead.setdefault(lead, []).append(f)
    # check's lines: beyond a few of one kind about sensors, the rest share one line
    said_by = {lead: [line for _, line in finding_lines(fs)] for lead, fs in by_lead.items()}
    for lead, messages in said_by.items():
        if len(messages) == 1:
            print(f"  {lead} (`lamde-mission check` says CANNOT): {messages[0]}",
                  file=sys.stderr)
            continue
        print(f"  {lead} (`lamde-mission check` says CANNOT):", file=sys.stderr)
        for message in messages:
            print(f"    CANNOT  {message}", file=sys.stderr)


def _cannot(m: Any, on_setup: Callable[[str | None], None] | None = None
            ) -> tuple[list[str], str]:
    """What `lamde-mission check` says CANNOT for map `m` (`diagnose`'s fatal findings: what no
    plan can meet), found before planning: its necessary conditions cost 0.2-1.7 % of a
    default plan's CPU time on T16, L02, L03 and L08, against minutes of a search that cannot
    succeed (a 2,000-footprint campus that C3 rules out: refused in 15 s, where the plan took
    143 s to fail). The planning map it judges is the one the plan then uses (cached on `m`).

    Args:
        m: the loaded map (a `planner_core.model.mapio.Map`).
        on_setup: the plan's `on_setup` (`SetupNotice`): told of the two stages, so a slow
            one on a large map gets its line; None: nothing.

    Returns:
        (the CANNOT findings' sentences, in `check`'s order, empty when there is none; what
        they mean, in `check`'s words: "no plan can meet this map", or "the sortie planner
        cannot plan this map" where each is the sortie planner's own limit).
    """
    from lamde_mission.commands.check import _cannot_what
    from planner_core.model.diagnose import diagnose

    def stage(name: str | None) -> None:
        if on_setup is not None:
            on_setup(name)

    stage("inflating the map's obstacles by their clearance")
    m.planning_map()
    stage("checking what no plan can meet (as `lamde-mission check` does)")
    d = diagnose(m)
    stage(None)
    return [f.message for f in d.findings if f.fatal], _cannot_what(d, "this map")


class SetupNotice:
    """`make_plan`'s on_setup (the instance) and on_setup_progress (`fraction`) for the CLI: a
    setup stage still running after `after` seconds gets a line on stderr (its name;
    --time-limit does not cut it), and the time it took when it ends. Quick stages print
    nothing. A shown stage that tells how far it is (the visibility graph) gets a line of its
    own beneath the name, "setup: the visibility graph  35 %, 21 s": on a TTY updated in place
    (at most every `EVERY` s) and overwritten by the time taken, otherwise a line per quarter,
    as the plan's progress bar does. `close` ends an interrupted stage's line without a time
    taken. A timer thread per stage; O(1) a call."""

    #: seconds between two updates of a TTY's percentage line
    EVERY = 0.2

    def __init__(self, after: float = 1.0, stream: Any = None) -> None:
        import threading

        self.after = after
        self._lock = threading.Lock()  # the timer thread's line and the caller's
        self._timer: Any = None
        self._stage = 0  # which stage's timer may still show its name
        self._t0 = 0.0
        self._shown = False
        self._part: tuple[str, float] | None = None  # the running stage's (what, fraction)
        # the percentage line (stream None: the sys.stderr of the moment); off a TTY once past
        # each quarter short of 1.0
        self._line = _StatusLine(stream, every=self.EVERY, step=0.25, tty=self._tty)

    def _out(self) -> Any:
        return self._line.out

    def _tty(self) -> bool:
        return bool(getattr(self._out(), "isatty", lambda: False)())

    def _show(self, name: str, stage: int) -> None:
        with self._lock:
            if stage != self._stage:  # the stage ended while the timer fired
                return
            self._shown = True
            print(f"setup: {name}... (not cut by --time-limit)", file=self._out(), flush=True)
            if self._part is not None and self._tty():  # off a TTY: from the next quarter
                self._say_part(*self._part, force=True)

    def _say_part(self, what: str, frac: float, force: bool = False) -> None:
        """The percentage line of the running, shown stage (the lock held): on a TTY at most
        every `EVERY` s (`force`: now), otherwise once past each quarter short of 1.0."""
        now = time.perf_counter()
        self._line.every = self.EVERY  # an instance may set its own
        self._line.show(f"setup: {what} {100 * frac:3.0f} %, {now - self._t0:.0f} s", frac,
                        now, force=force)

    def fraction(self, what: str, frac: float) -> None:
        """The running stage is `frac` of the way through `what` (`make_plan`'s
        on_setup_progress): shown once the stage's name is.

        Args:
            what: what the stage is doing ("the visibility graph").
            frac: the fraction of it done, in [0, 1].
        """
        with self._lock:
            self._part = (what, frac)
            if self._shown:
                self._say_part(what, frac)

    def _end(self, done: bool) -> None:
        """End the running stage (the lock held): its timer, its open line, and, when `done`
        and shown, the time it took."""
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        self._stage += 1
        self._line.end(f"setup: done in {time.perf_counter() - self._t0:.1f} s"
                       if self._shown and done else None)  # fmt: skip
        self._shown = False
        self._part = None

    def __call__(self, name: str | None) -> None:
        import threading

        with self._lock:
            self._end(done=True)
            if name is not None:
                self._t0 = time.perf_counter()
                self._timer = threading.Timer(self.after, self._show, args=(name, self._stage))
                self._timer.daemon = True
                self._timer.start()

    def close(self) -> None:
        """End a stage cut short (Ctrl-C, an error): no time taken is claimed, an open TTY line
        is ended so that what is printed next starts on its own (idempotent)."""
        got = self._lock.acquire(timeout=1.0)  # a Ctrl-C inside `fraction` released it
        try:
            self._end(done=False)
        finally:
            if got:
                self._lock.release()


def _corner_slots(args: argparse.Namespace) -> int | str:
    """`--corner-slots` as "auto" or an integer in [0, MAX_CORNER_SLOTS]
    (`planner_core.model.corner_slots.check_corner_slots`, the API's check).

    Raises:
        UsageError: anything else, one line.
    """
    from lamde_mission.errors import UsageError
    from planner_core.model.corner_slots import check_corner_slots
    from planner_core.textio import printable

    text = str(args.corner_slots).strip()
    if text == "auto":
        return "auto"
    try:
        return check_corner_slots(int(text))
    except ValueError as e:
        if "more than" in str(e):
            raise UsageError("--corner-slots" + str(e).removeprefix("corner_slots")) from None
        raise UsageError(f"--corner-slots: must be 'auto' or an integer >= 0, got "
                         f"{printable(str(args.corner_slots))!r}") from None


def run(args: argparse.Namespace) -> int:
    """`plan MAP -o OUT`: plan, store, replay and judge the mission, then write it (and the
    --plot and --report); a map with a battery or fleet is planned as sorties
    (`_run_sorties`). Every option and output is checked before the optimisation, and so is
    the map: one `check` says CANNOT for is refused unless --allow-infeasible (`_cannot`).

    Args:
        args: the parsed options.

    Returns:
        0 ok, 1 infeasible (nothing written, or written with --allow-infeasible; a map no
        plan can meet: refused before planning, nothing written).

    Raises:
        UsageError: a bad option, map or output (one line per problem, exit 2).
    """
    peeked = _peek_map(args.map)
    if peeked is None:  # a map that does not load says why first (not "no battery", a suffix)
        from lamde_mission.commands._common import load_map_or_fail

        peeked = load_map_or_fail(args.map)
    if peeked.has_battery or peeked.has_fleet:
        return _run_sorties(args, peeked)
    for opt, given in (("--objective", args.objective), ("--sortie-budget", args.sortie_budget),
                       ("--rounds", args.rounds)):
        if given is not None:
            from lamde_mission.errors import UsageError

            raise UsageError(f"{opt}: the map has no battery and no fleet (one flight, the "
                             "paper's f)")
    from lamde_mission.commands._common import (
        check_outputs,
        load_map_or_fail,
        with_origin_or_fail,
    )
    from lamde_mission.errors import UsageError
    from planner_core.textio import printable

    # check every output before the (long) optimisation, so bad input fails fast: the paths
    # first, before the mission formats (and the simulator under them) are even imported
    if args.plot and not args.plot.lower().endswith((".png", ".svg")):
        raise UsageError(f"--plot: {args.plot}: image format must be PNG or SVG (.png or .svg)")
    if args.format:  # one that disagrees with OUT's suffix: before --mkdir makes a folder
        from lamde_mission.formats import MissionFileError, format_for

        try:
            format_for(args.output, args.format)
        except MissionFileError as exc:
            raise UsageError(f"--format: {exc}") from None
    if args.output.endswith(("/", os.sep)) or os.path.isdir(args.output):
        what = "is a folder" if os.path.isdir(args.output) else "names a folder"
        raise UsageError(
            f"-o/--output: {printable(args.output)}: {what}; a map without a battery or "
            "fleet is planned as a single flight into one file (.plan, .waypoints or "
            ".geojson); a folder of sorties is for a map with uav.battery, uav.endurance_s or "
            "fleet")
    check_outputs(
        [("-o/--output", args.output), ("--plot", args.plot), ("--report", args.report)],
        mkdir=args.mkdir, inputs=[("map", args.map)],
    )
    from lamde_mission.formats import MissionFileError, format_for

    try:
        fmt = format_for(args.output, args.format)
    except MissionFileError as exc:
        raise UsageError(f"-o/--output: {exc}") from None
    try:
        D.check_run_args(population=args.population, budget=args.budget, starts=args.starts)
        D.check("seed", args.seed)
        if args.time_limit is not None:
            D.check("time_limit", args.time_limit)
    except ValueError as exc:  # "population: must be ...": name the option as typed
        raise UsageError("--" + str(exc).replace("_", "-", 1)) from None
    from planner_core.pipeline.schedule import make_scheduler

    try:
        make_scheduler(args.scheduler)
    except ValueError as exc:
        raise UsageError(f"--{exc}") from None
    corner_slots = _corner_slots(args)
    if corner_slots != "auto" and corner_slots and args.fixed_length:
        raise UsageError("--corner-slots: not with --fixed-length (it flies every slot)")
    configurator = args.configurator
    if args.policy is not None:
        if args.configurator != "lamde":
            raise UsageError("--policy: only with --configurator lamde")
        from planner_core.learning.policy import CheckpointError, PolicyConfigurator

        try:
            configurator = PolicyConfigurator(checkpoint=args.policy)
        except CheckpointError as exc:
            raise UsageError(f"--policy: {exc}") from None
    m = load_map_or_fail(args.map, loaded=peeked)
    m = with_origin_or_fail(m, args.origin)
    if args.finish == "rtl":
        _check_return_leg(m)

    from lamde_mission.api import kernels_cached
    from lamde_mission.api import plan as make_plan
    from lamde_mission.formats import write_mission
    from lamde_mission.items import plan_to_items
    from lamde_mission.storage import storable_plan, stored_items
    from sim import replay, verify

    cached = kernels_cached()

    def announce() -> None:
        if args.quiet:
            return
        print("compiling the planner's kernels (first run after install; they are cached on "
              "disk for later runs)..." if not cached else "loading the planner's compiled "
              "kernels...", file=sys.stderr, flush=True)

    progress = None if args.quiet else _ProgressBar()
    setup = None if args.quiet else SetupNotice()
    try:
        # a map `check` says CANNOT is refused before the search (it would run its whole
        # budget to fail); --allow-infeasible plans and writes it as before
        cannot, what = ([], "") if args.allow_infeasible else _cannot(m, setup)
        if cannot:
            from planner_core.textio import printable

            print(f"lamde-mission plan: no feasible mission for {printable(args.map)}: "
                  f"`lamde-mission check` says CANNOT ({what}), so it was not planned; "
                  "nothing written:", file=sys.stderr)  # fmt: skip
            for line in cannot:
                print(f"  CANNOT  {printable(line)}", file=sys.stderr)
            print("  --allow-infeasible plans it anyway and writes the mission (exit status 1)",
                  file=sys.stderr)  # fmt: skip
            return 1
        plan = make_plan(
            m,
            seed=args.seed,
            budget=args.budget,
            population=args.population,
            configurator=configurator,
            init=args.init,
            memetic=args.memetic,
            starts=args.starts,
            descent=not args.no_descent,
            variable_length=not args.fixed_length,
            polish=not args.no_polish,
            time_limit=args.time_limit,
            progress=progress,
            on_compile=announce,
            scheduler=args.scheduler,
            corner_slots=corner_slots,
            on_setup=setup,
            on_setup_progress=None if setup is None else setup.fraction,
        )
    finally:
        if setup is not None:  # an interrupted stage: its line ended, no "done in" claimed
            setup.close()
        if progress is not None:
            progress.close()
    pm = m.planning_map()
    stored = storable_plan(plan, m, args.autopilot, planning_map=pm, finish=args.finish)
    items = stored_items(plan_to_items(stored, m, finish=args.finish), stored.dialect)
    timeline = replay(items, m)
    verdicts = verify(timeline, m)
    feasible = verdicts.passed
    if not feasible and not args.allow_infeasible:
        from planner_core.textio import printable

        if not args.quiet:
            print(_summary(plan, m, timeline, verdicts, None, stored,
                           every_sensor=args.verbose))
        if plan.feasible:  # the plan met the model; the mission as stored does not
            print(f"lamde-mission plan: the plan for {printable(args.map)} is feasible, but "
                  f"not once stored as {stored.dialect.name} stores it (1e-7 degree lat/lon, "
                  "float32, hover time resolution); nothing written:", file=sys.stderr)  # fmt: skip
        else:
            print(f"lamde-mission plan: no feasible mission found for {printable(args.map)} "
                  f"(budget {args.budget}, seed {args.seed}); nothing written:", file=sys.stderr)
        for line in _violations(plan, verdicts):
            print(f"  {line}", file=sys.stderr)
        if not plan.feasible:  # `_cannot` found nothing no plan can meet before the plan
            print("  try a larger --budget, another --seed, or --allow-infeasible to write "
                  "it anyway", file=sys.stderr)  # fmt: skip
        return 1
    # the mission goes to a hidden file beside its target first and is renamed last: a run
    # killed between the renames leaves the new plot and report with an older mission, which
    # the report's mission_sha256 tells apart, never a new mission beside an older report
    import hashlib
    from pathlib import Path

    from planner_core.atomic import clean_stale_temps, pending_path, replace_keeping_mode

    target = Path(args.output)
    clean_stale_temps(target)  # what a killed run left beside it
    pending = pending_path(target)
    writing = ("-o/--output", args.output)  # the output being written, for an OSError's line
    try:
        write_mission(pending, stored, m, fmt, finish=args.finish, autopilot=args.autopilot,
                      planning_map=pm)
        if args.plot:
            from lamde_mission.plot import plot_mission

            writing = ("--plot", args.plot)
            plot_mission(m, args.plot, timeline=timeline, plan=plan)
        if args.report:
            writing = ("--report", args.report)
            from lamde_mission.atomic import write_text_atomic

            report = {"plan": plan.to_dict(), "verdicts": verdicts.to_dict(),
                      "stored": {"autopilot": stored.dialect.name, "finish": args.finish,
                                 "hover_points": stored.hover_points.tolist(),
                                 "hover_times": stored.hover_times.tolist()},
                      "sensors": _sensor_rows(m, timeline),
                      "map": args.map, "output": args.output, "format": fmt,
                      "mission_sha256": hashlib.sha256(pending.read_bytes()).hexdigest()}
            write_text_atomic(args.report, json.dumps(report, indent=2))
        writing = ("-o/--output", args.output)
        replace_keeping_mode(pending, target)  # an overwritten 0600 mission stays 0600
    except OSError as exc:  # past the output check (disk full, a race): one line, no traceback
        from planner_core.textio import printable

        raise UsageError(f"{writing[0]}: {printable(writing[1])}: cannot write "
                         f"({exc.strerror or exc}); the mission was not written") from None
    finally:
        pending.unlink(missing_ok=True)
    if not args.quiet:
        print(_summary(plan, m, timeline, verdicts,
                       [p for p in (args.output, args.plot, args.report) if p], stored,
                       every_sensor=args.verbose))
    if not feasible:
        print("lamde-mission plan: the mission is INFEASIBLE (written because of "
              "--allow-infeasible):", file=sys.stderr)
        for line in _violations(plan, verdicts):
            print(f"  {line}", file=sys.stderr)
        return 1
    return 0

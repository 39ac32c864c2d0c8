"""`lamde-mission verify MAP MISSION`: replay a mission file in the sim and judge C1..C5."""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from typing import Any


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `lamde-mission verify` (options, help).

    Args:
        sub: the subcommands of `lamde_mission.cli.build_parser`.

    Returns:
        The command's parser (`build_parser` sets `run` as its `_run`).
    """
    p = sub.add_parser(
        "verify",
        help="replay a mission file in the simulator and check constraints C1..C5",
        description="Fly a mission file (QGroundControl .plan, ArduPilot .waypoints, or a saved "
        "plan result .json) over MAP with the paper's model, independently of the optimiser, and "
        "print a verdict per constraint with its margin. Exit status: 0 all pass, 1 any fails, "
        "2 bad input. MISSION may be a sortie directory (`plan MAP -o DIR/` for a map with a "
        "battery or fleet): each mission-v{vehicle}-s{sortie}.plan is replayed from its depot "
        "to its depot (fleet.json names them), with C1-C3, C5, ENDS, CLEAR and ENERGY per "
        "sortie, C4 and MARGIN over the data of all sorties together, and the plan's shape: "
        "CHAIN (each vehicle takes off where its last sortie landed), UAVS (no more "
        "vehicles than the map's fleet.uavs) and FILES (no mission file in DIR that "
        "fleet.json does not list). Items are named as they go up to the vehicle: numbered "
        "from 0, a .waypoints file's home line left out, so item N is QGroundControl's item "
        "N+1, a .waypoints file's line with seq N+1 and an ArduPilot vehicle's seq N+1 (its "
        "seq 0 is home); PX4's seq N.",
    )
    p.add_argument("map", help="map file (JSON)")
    from lamde_mission.commands._common import add_origin_option

    add_origin_option(p)
    p.add_argument("mission", help="mission file: .plan, .waypoints (or a plan result .json), "
                   "or a sortie directory DIR/ holding fleet.json")
    p.add_argument("--json", action="store_true", help="print verdicts and totals as JSON")
    return p


def replay_mission_file(path: str, m: Any) -> Any:
    """Read a mission file and replay it on map `m`; its notes go to stderr.

    Args:
        path: the mission file (.plan, .waypoints or a plan result .json).
        m: the map (with its origin).

    Returns:
        The `sim.replay.Timeline`.

    Raises:
        UsageError: bad input (a file that cannot be read, a mission the sim cannot fly).
    """
    from lamde_mission.errors import UsageError
    from lamde_mission.formats import MissionFileError, load_mission_items
    from lamde_mission.items import MissionError
    from planner_core.textio import printable
    from sim import replay

    try:
        items, _fence = load_mission_items(path, m)
    except MissionFileError as exc:
        raise UsageError(str(exc)) from None
    try:
        timeline = replay(items, m)
    except MissionError as exc:
        raise UsageError(f"{printable(path)}: {exc}") from None
    for note in timeline.notes:
        print(f"note: {printable(path)}: {printable(note)}", file=sys.stderr)
    return timeline


def check_sortie_dir(m: Any, path: str) -> Any:
    """Replay and judge a sortie directory as `verify MAP DIR/` does (`upload DIR/ --fleet
    --map MAP` too): `lamde_mission.sorties.verify_sortie_dir`, its notes on stderr.

    Args:
        m: the map (with its origin).
        path: the sortie directory.

    Returns:
        The `lamde_mission.sorties.FleetCheck`.

    Raises:
        UsageError: a bad directory, fleet.json field or mission file (one line naming it).
    """
    from lamde_mission.errors import UsageError
    from lamde_mission.sorties import verify_sortie_dir

    try:
        check = verify_sortie_dir(m, path)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    for note in check.notes:
        print(f"note: {note}", file=sys.stderr)
    return check


def _run_sorties(args: argparse.Namespace, m: Any) -> int:
    """`verify MAP DIR/`: every sortie of a sortie directory, and the whole plan."""
    from lamde_mission.commands._common import fleet_makespan_words
    from lamde_mission.sorties import pad_words
    from planner_core.textio import counted, printable

    check = check_sortie_dir(m, args.mission)
    if args.json:
        out = {"sorties": [{"vehicle": s.vehicle, "sortie": s.sortie, "file": s.file,
                            "depot_start": s.depot_start, "depot_end": s.depot_end,
                            "takeoff_s": at,
                            "duration_s": s.duration_s, "sensors": list(s.sensors),
                            "collected_mbit": s.collected_mbit,
                            **s.verdicts.to_dict()}
                           for s, at in zip(check.sorties, check.takeoffs(), strict=True)],
               "combined": [v.to_dict() for v in check.combined],
               "fleet": [v.to_dict() for v in check.fleet], "notes": list(check.notes),
               "launch_s": {str(v): check.launch(v) for v in check.vehicles()},
               "makespan_s": {str(v): check.makespan(v) for v in check.vehicles()},
               "fleet_makespan_s": check.fleet_makespan[0],
               "total_s": check.total_s, "swaps": check.swaps, "f_total": check.f_total,
               "timing_tolerance_s": check.timing_tolerance_s, "passed": check.passed}
        print(json.dumps(out, indent=2))
    else:
        print(f"sortie directory {printable(args.mission)} on map '{printable(m.name)}': "
              f"{counted(len(check.sorties), 'sortie')} on "
              f"{counted(len(check.vehicles()), 'vehicle')}")
        for s, at in zip(check.sorties, check.takeoffs(), strict=True):
            vd = s.verdicts
            energy = (f", energy {vd.energy_wh:.3f} Wh of {vd.usable_wh:.3f} usable, "
                      f"{vd.above_reserve_wh:.3f} Wh left above the reserve "
                      f"({vd.reserve_left_wh:.3f} Wh in the battery)") \
                if vd.energy_wh is not None else ""
            print(f"{printable(s.file)}: {pad_words(m, s.depot_start, s.takeoff_xy)} -> "
                  f"{pad_words(m, s.depot_end, s.landing_xy)}, take-off +{at:.0f} s, "
                  f"{s.duration_s:.1f} s{energy}, "
                  f"data from {counted(len(s.sensors), 'sensor')}")
            print("\n".join("  " + printable(r) for r in vd.table().splitlines()))
            print("  " + printable(_sortie_data(s, m)))
        for v in check.vehicles():
            print(f"vehicle {v}: launch at +{check.launch(v):.0f} s, makespan "
                  f"{check.makespan(v):.1f} s")
        for v in check.combined:
            print(f"whole plan {v.name} {v.title}: {'PASS' if v.passed else 'FAIL'}, margin "
                  f"{v.margin:.6g} {v.unit}; {printable(v.detail)}")
        for v in check.fleet:
            print(f"fleet {v.name} {v.title}: {'PASS' if v.passed else 'FAIL'}; "
                  f"{printable(v.detail)}")
        print(f"total {check.total_s:.1f} s with {counted(check.swaps, 'battery swap')}; "
              f"f summed + swaps {check.f_total:.3f}{fleet_makespan_words(check)}")
        print("result: " + ("all constraints hold" if check.passed
                            else "FAILED " + "; ".join(printable(x) for x in check.failed())))
    return 0 if check.passed else 1


def run(args: argparse.Namespace) -> int:
    """`verify MAP MISSION` (or a sortie directory): replay and judge, as text or JSON.

    Args:
        args: the parsed options.

    Returns:
        0 when every check passes, 1 when any fails.

    Raises:
        UsageError: a bad map, origin, mission file or sortie directory (one line per
            problem, exit 2).
    """
    from pathlib import Path

    from lamde_mission.commands._common import (
        clearance_words,
        load_map_or_fail,
        with_origin_or_fail,
    )
    from sim import verify

    m = load_map_or_fail(args.map)
    m = with_origin_or_fail(m, args.origin)
    if Path(args.mission).is_dir():
        return _run_sorties(args, m)
    timeline = replay_mission_file(args.mission, m)
    verdicts = verify(timeline, m)
    t = timeline.totals
    from lamde_mission.items import corner_stops, flown_again

    n_corner = len(corner_stops(timeline.route))
    from lamde_mission.sorties import looks_like_a_sortie, sortie_dir_of

    sortie_dir = sortie_dir_of(args.mission)
    whole = None if sortie_dir is None else \
        f"lamde-mission verify {shlex.quote(args.map)} {shlex.quote(f'{sortie_dir}/')}"
    if args.json:
        out = verdicts.to_dict()
        if sortie_dir is not None:  # one sortie judged as a whole mission (the verdicts as such)
            out["sortie_of"] = {"directory": str(sortie_dir), "verify": whole}
        # corners (NAV_WAYPOINT, flown through) are counted apart from the hover points
        out["hover_points"] = len(timeline.hover_times)
        out["corners"] = n_corner
        # a DO_JUMP loop: each pass counted above; {seq: passes} of the items flown again
        out["flown_again"] = {str(k): n for k, n in flown_again(timeline.route).items()}
        out["totals"] = {
            "t_fly": t.t_fly, "t_hover": t.t_hover, "f": t.f, "t_takeoff": t.t_takeoff,
            "t_land": t.t_land, "t_return": t.t_return, "t_total": t.t_total,
            "distance": t.distance, "collected": t.collected,
        }  # fmt: skip
        print(json.dumps(out, indent=2))
    else:
        from planner_core.textio import counted, printable

        corners = (f" + {counted(n_corner, 'corner')} (NAV_WAYPOINT, flown through; not hover "
                   "points)" if n_corner else "")  # fmt: skip
        loop = loop_words(timeline.route)
        print(f"mission {printable(args.mission)} on map '{printable(m.name)}': "
              f"{counted(len(timeline.hover_times), 'hover point')}{corners}"
              f"{', ' + loop if loop else ''}")  # fmt: skip
        print("\n".join(printable(r) for r in verdicts.table().splitlines()))
        sf = m.spec.safety
        kept = clearance_words(verdicts.clearance, ".3f")
        print(f"safety: clearance {kept} (asked {sf.clearance:g} m); data "
              f"margin per sensor (asked {100 * sf.data_margin:g} %): "
              f"{_margins(verdicts.data_margins)}")
        print(f"f = {t.f:.6f}  (alpha {t.alpha:g}: t_fly {t.t_fly:.3f} s, "
              f"t_hover {t.t_hover:.3f} s)")  # fmt: skip
        print(_time_line(timeline))
        if verdicts.energy_wh is not None:  # a map with a battery (docs/energy.md)
            left = verdicts.reserve_left_wh
            print(f"energy {verdicts.energy_wh:.3f} Wh of {verdicts.usable_wh:.3f} Wh usable "
                  f"(battery {verdicts.battery_wh:.3f} Wh less its reserve); left at landing "
                  f"{left:.3f} Wh, {100 * left / verdicts.battery_wh:.1f} % of the battery, "
                  f"{verdicts.above_reserve_wh:.3f} Wh above the reserve")
        print("result: " + ("all constraints hold" if verdicts.passed
                            else "FAILED " + ", ".join(verdicts.failed)))  # fmt: skip
        if sortie_dir is not None:
            print(f"note: {printable(args.mission)} is one sortie of the sortie directory "
                  f"{printable(str(sortie_dir))}/, judged here against the whole map's start, "
                  "end and data; for the sortie's own depots and the data over all sorties run "
                  f"`{printable(whole)}`")
        elif looks_like_a_sortie(args.mission):
            print(f"note: {printable(args.mission)} is named as one sortie of a sortie "
                  "directory, judged here against the whole map's start, end and data; a "
                  "sortie is verified with its directory (`lamde-mission verify MAP DIR/`, DIR "
                  "holding fleet.json), which is not beside this file")
    return 0 if verdicts.passed else 1


def _sortie_data(s: Any, m: Any) -> str:
    """verify DIR/'s line of what one sortie collects: each sensor it serves with its Mbit and
    share of the sensor's requirement (the first `MARGINS_LISTED` by name, then a count);
    judged only with the other sorties' data (the whole plan's C4 and MARGIN), which it says.

    Args:
        s: the `lamde_mission.sorties.SortieCheck`.
        m: the plan's map (each sensor's required data).

    Returns:
        One line (no newline, no indent).
    """
    req = dict(zip(m.sensor_ids, (float(q) for q in m.required_data), strict=True))
    got = s.collected_mbit
    if not got:
        return "data: collects from no sensor (C4 and MARGIN judge all sorties together, below)"
    parts = [f"'{k}' {q:.6g} Mbit" + (f" ({100 * q / req[k]:.3g} % of its {req[k]:g} Mbit)"
                                      if req.get(k, 0.0) > 0 else "")
             for k, q in list(got.items())[:MARGINS_LISTED]]  # fmt: skip
    more = f" and {len(got) - MARGINS_LISTED} more" if len(got) > MARGINS_LISTED else ""
    return (f"data: collects {', '.join(parts)}{more}; C4 and MARGIN judge all sorties "
            "together (whole plan, below)")


def loop_words(route: Any) -> str:
    """What `verify`'s count line adds for a DO_JUMP loop: every pass of a stop counts (a loop
    flying a hover point 3 times makes 3 hover points), and the last WAYPOINT's last pass is
    the end point, not a corner, so a loop flying a LOITER_TIME and a WAYPOINT 3 times each
    counts 3 hover points + 2 corners; the words say so.

    Args:
        route: a mission read back by `items_to_route` (`sim.mission.Route`).

    Returns:
        "" without a loop; else e.g. "counting each pass of a DO_JUMP loop: items 1-2 flown 3
        times; item 2's last pass is the end point, not a corner" (items by seq; a run of
        items flown equally often as one range, at most 3 runs named). O(n log n) in the
        number of stops.
    """
    from lamde_mission.items import end_point_index, flown_again
    from planner_core.textio import first_few

    again = flown_again(route)
    if not again:
        return ""
    seqs = sorted(set(route.seqs))
    counts = {s: 1 for s in seqs} | again
    runs: list[list[int]] = []  # [first seq, last seq, passes], passes > 1
    last_n = 0  # the passes of the item before, in seq order
    for s in seqs:
        n = counts[s]
        if n > 1 and n == last_n:
            runs[-1][1] = s
        elif n > 1:
            runs.append([s, s, n])
        last_n = n
    times = {2: "twice"}
    parts = [(f"item {a}" if a == b else f"items {a}-{b}") + f" flown {times.get(n, f'{n} times')}"
             for a, b, n in runs]  # fmt: skip
    out = f"counting each pass of a DO_JUMP loop: {first_few(parts, 3)}"
    end = end_point_index(route)
    if end is not None and route.seqs[end] in again:
        out += f"; item {route.seqs[end]}'s last pass is the end point, not a corner"
    return out


def _time_line(timeline: Any) -> str:
    """verify's mission-time line: the total with its take-off, landing and return, each said
    as the mission has it: a take-off without a TAKEOFF item is the sim's assumption, and a
    mission without LAND or RETURN_TO_LAUNCH has no landing.

    Args:
        timeline: the replay (`sim.replay.Timeline`).

    Returns:
        One line (no newline).
    """
    t, route = timeline.totals, timeline.route
    take_off = (f"take-off {t.t_takeoff:.1f} s" if route.takeoff_altitude is not None else
                f"take-off {t.t_takeoff:.1f} s assumed (no TAKEOFF item)")
    landing = (f"landing {t.t_land:.1f} s" if route.finish != "none" else
               "no landing (it holds at its last stop)")
    ret = f", return {t.t_return:.1f} s" if t.t_return else ""
    return (f"mission time {t.t_total:.1f} s including {take_off}, {landing}{ret}; distance "
            f"{t.distance:.1f} m")


#: sensors whose data margins verify lists by name; beyond, the least of them and a summary
MARGINS_LISTED = 12


def _margins(margins: dict[str, float]) -> str:
    """verify's per-sensor data margins (fractions): every sensor by name up to
    `MARGINS_LISTED`, else the 10 least and the count, least and median of all."""
    from planner_core.textio import printable

    def one(k: str, v: float) -> str:
        return f"'{printable(k)}' {100 * v:+.3g} %"

    if len(margins) <= MARGINS_LISTED:
        return ", ".join(one(k, v) for k, v in margins.items())
    least = sorted(margins.items(), key=lambda kv: kv[1])[:10]
    vals = sorted(margins.values())
    return (", ".join(one(k, v) for k, v in least)
            + f" (the 10 least of {len(vals)} sensors; median {100 * vals[len(vals) // 2]:+.3g} %,"
              f" most {100 * vals[-1]:+.3g} %)")

"""`lamde-mission check MAP`: validate a map and print its summary."""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from typing import Any


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `lamde-mission check` (options, help).

    Args:
        sub: the subcommands of `lamde_mission.cli.build_parser`.

    Returns:
        The command's parser (`build_parser` sets `run` as its `_run`).
    """
    p = sub.add_parser(
        "check",
        help="validate a map file and print its summary",
        description="Validate a map file: every problem is reported on its own line naming the "
        "field (exit status 2). On success print counts, area, I_max and the defaults in force, "
        "then a fast feasibility diagnosis (sensors no reachable hover point can serve, data "
        "that cannot fit within max_hover_time x max_hover_points, more sensors pairwise "
        "beyond twice the radio reach than max_hover_points, an end point walled off, "
        "sensors that no hover point keeping C3 (the bandwidth R_lambda under the paper's "
        "simultaneous uplink) can serve; on a map with a battery or fleet, a sensor no sortie "
        "from where a vehicle can take off can reach and come back from within the usable "
        "energy, more sensors needing vehicles of their own than fleet.uavs, depots no "
        "sortie can leave (all of them: one among others is a note) or a depot without room "
        "for every vehicle's own pad, and a sensor needing "
        "more sorties than the sortie planner makes for one; exit status 1 naming what "
        "cannot be met; docs/energy.md).",
    )
    p.add_argument("map", help="map file (JSON)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    return p


def run(args: argparse.Namespace) -> int:
    """`check MAP`: the map's summary and the fast feasibility diagnosis, as text or JSON.

    Args:
        args: the parsed options (`map`, `json`).

    Returns:
        0 when nothing rules every plan out, 1 when the diagnosis finds something fatal.

    Raises:
        UsageError: the map cannot be read or is invalid (one line per problem, exit 2).
    """
    from lamde_mission.commands._common import load_map_or_fail
    from planner_core.model.diagnose import diagnose

    m = load_map_or_fail(args.map)
    s = m.summary()
    d = diagnose(m)
    if args.json:
        if s.get("fleet") is not None and int(m.uavs) > 1:
            s["fleet"]["pads"] = _pads_json(m)
        s["diagnosis"] = [{"kind": f.kind, "fatal": f.fatal, "sensor": f.sensor,
                           "message": f.message, **({"depot": f.depot} if f.depot else {})}
                          for f in d.findings]  # fmt: skip
        if s["has_witness"]:
            from planner_core.suite import witness_score

            score = witness_score(m)
            s["witness"] = None if score is None else {"f": score[0], "phi": score[1],
                                                       "feasible": score[1] == 0.0}
        print(json.dumps(s, indent=2))
        return 0 if d.feasible_so_far else 1
    default = " (default for this size)" if s["max_hover_points_default"] else ""
    u, r, o = s["uav"], s["radio"], s["objective"]
    from planner_core.textio import counted, printable

    print(f"map '{printable(s['name'])}': " + ("OK" if d.feasible_so_far else
                                    f"valid, but {_cannot_what(d)} (CANNOT below)"))
    print(f"  area            {s['area_m'][0]:g} m x {s['area_m'][1]:g} m")
    if s["origin"] is None:
        print("  origin          none: give one (or --origin LAT,LON[,ALT]) to write a mission")
    else:
        print(f"  origin          lat {s['origin']['lat']}, lon {s['origin']['lon']}, "
              f"alt {s['origin']['alt']} m")
    print(f"  start -> end    ({s['start'][0]:g}, {s['start'][1]:g}) -> "
          f"({s['end'][0]:g}, {s['end'][1]:g})")
    print(f"  sensors         {s['sensors']} (total required {s['total_required_data_mbit']:g} "
          "Mbit)")
    print(f"  obstacles       {counted(s['circles'], 'circle')}, "
          f"{counted(s['rectangles'], 'rectangle')}, {counted(s['polygons'], 'polygon')}, "
          f"{counted(s['no_fly_zones'], 'no-fly zone')}")
    print(f"  I_max           {s['max_hover_points']}{default}")
    print(f"  uav             H {u['altitude']:g} m, v_max {u['max_speed']:g} m/s, "
          f"a {u['acceleration']:g} m/s^2, T_max {u['max_hover_time']:g} s, "
          f"tau {u['activation_threshold']:g}")
    print(f"  radio           R_c {r['peak_rate']:g} Mbit/s, xi {r['decay']:g} Mbit/s/m, "
          f"R_lambda {r['bandwidth']:g} Mbit/s, Q_lambda {r['required_data']:g} Mbit, "
          f"access {r.get('access', 'simultaneous')}")
    print(f"  objective       alpha {o['alpha']:g}, mu {o['collision_offset']:g}, "
          f"nu {o['collision_weight']:g} /m")
    if s["has_witness"]:
        print(f"  witness         {_witness_line(m)}")
    sf = s["safety"]
    # the paper's model has none (its maps, the generator's): a field mission wants a few
    # metres, which a reviewer did not see said anywhere
    bare = (" (none: legs may touch the obstacles' edges; a field mission wants a few "
            "metres: safety.clearance)" if sf["clearance"] == 0 and len(m.obstacle_labels)
            else "")
    print(f"  safety          clearance {sf['clearance']:g} m{_reduced_clearance(m)}{bare}, "
          f"data margin {100 * sf['data_margin']:g} %")
    _energy_lines(s, m)
    return _diagnosis(d)


def _witness_line(m: object) -> str:
    """What the map's stored witness plan proves: feasible on the map as it is (a plan exists),
    or not any more (a map edited since it was stored; nothing plans from it)."""
    from planner_core.suite import witness_score

    score = witness_score(m)
    if score is None:
        return "a stored plan with more hover points than I_max: it proves nothing here"
    f, phi = score
    if phi == 0.0 and (getattr(m, "has_battery", False) or getattr(m, "has_fleet", False)):
        return (f"a stored single flight feasible on this map (f {f:.6g}), battery left aside: "
                "it proves nothing about sorties")
    if phi == 0.0:
        return f"a stored plan feasible on this map (f {f:.6g}): a plan exists"
    return (f"a stored plan NOT feasible on this map as it is now (phi {phi:.4g}; edited "
            "since it was stored?): it proves nothing, and nothing plans from it")


def _reduced_clearance(m: object) -> str:
    """', less where the start, end or a depot is closer: ...' naming the obstacles whose
    clearance in force (`Map.obstacle_clearances`) is below the asked one (up to three), or ''."""
    from planner_core.textio import first_few

    asked = float(m.spec.safety.clearance)
    less = [(lab, c) for lab, c in zip(m.obstacle_labels, m.obstacle_clearances, strict=True)
            if c < asked]
    if not less:
        return ""
    shown = first_few([f"{c:.3g} m at {lab}" for lab, c in less[:3]], total=len(less))
    return f" (less where the start, end or a depot is closer: {shown})"


def _pads_json(m: Any) -> dict[str, list[dict[str, float]]] | None:
    """{depot: [pad 2, pad 3, ...]} of a fleet's map (`Map.vehicle_pads`), each pad's local
    x, y and east_m, north_m from its depot; None when a depot has no room (PADS says why)."""
    try:
        pads = m.vehicle_pads
    except ValueError:
        return None
    names, xy, _ = m.sortie_sites
    return {n: [{"pad": k + 1, "x": float(pads[k, d, 0]), "y": float(pads[k, d, 1]),
                 "east_m": float(pads[k, d, 0] - xy[d][0]) + 0.0,
                 "north_m": float(pads[k, d, 1] - xy[d][1]) + 0.0}
                for k in range(1, len(pads))] for d, n in enumerate(names)}  # fmt: skip


def _energy_lines(s: dict, m: object) -> None:
    """The battery and fleet lines of the summary (issue 33), when the map gives them; the
    depots are the sortie planner's (`Map.sortie_sites` of map `m`: without `fleet.depots`,
    home at the start, and the map's end as a landing site)."""
    b, f = s.get("battery"), s.get("fleet")
    if b is not None:
        from planner_core.defaults import number_text

        # plain digits (90000 Wh, not 9e+04 Wh), rounded as the `:.4g` and `:.3g` they replace
        hover_w = s["power"]["hover_w"]
        given = (f"{number_text(b['endurance_s'])} s of hover = "
                 if b["endurance_s"] is not None else "")  # fmt: skip
        print(f"  battery         {given}{number_text(b['energy_wh'], 4)} Wh, reserve "
              f"{100 * b['reserve']:g} %: {number_text(b['usable_wh'], 4)} Wh usable per sortie "
              f"({number_text(60 * b['usable_wh'] / hover_w, 3)} min of hover at P(0) "
              f"{hover_w:g} W)")
    if f is not None:
        from planner_core.textio import counted, first_few, printable

        names, xy, _ = m.sortie_sites
        sites = [f"{printable(n)} ({x:g}, {y:g})" for n, (x, y) in zip(names, xy, strict=True)]
        # a long list named by its first few (100 depots made a line of 2,500 characters);
        # `check --json` lists them all
        where = first_few(sites, SHOWN_SITES)
        if f["depots_default"]:
            where = f"{sites[0]} at the start (default)" + (
                f" and {sites[1]} at the map's end (a landing site; a take-off site only "
                "after a landing there)" if len(sites) > 1 else "")
        print(f"  fleet           {counted(f['uavs'], 'UAV')}, depots "
              f"{where}, swap {f['swap_s']:g} s, separation {f['separation_m']:g} m, goal "
              f"{s['goal']}")
        pads = _pads_json(m) if f["uavs"] > 1 else None  # None: PADS says why below
        if pads is not None:
            from planner_core.model.pads import offset_words

            each = " | ".join(
                f"{printable(n)}: " + "; ".join(
                    f"pad {p['pad']} {offset_words(p['east_m'], p['north_m'])}"
                    for p in ps[:SHOWN_PADS]) + (
                    f"; and {len(ps) - SHOWN_PADS} more" if len(ps) > SHOWN_PADS else "")
                for n, ps in list(pads.items())[:SHOWN_SITES])  # fmt: skip
            more = len(pads) - SHOWN_SITES
            print(f"  pads            beside each depot, taken by the vehicles that use it "
                  f"in number order (pad 1, the first, is the depot): {each}"
                  + (f" | and {more} more depots' (`check --json` lists every pad)"
                     if more > 0 else ""))


#: findings of one kind about sensors printed in full; the rest of that kind (two or more)
#: share one line naming them
SHOWN_PER_KIND = 10
#: depots `check`'s fleet and pads lines name, and pads per depot, before "and N more"
SHOWN_SITES = 6
SHOWN_PADS = 8


def finding_lines(findings: Sequence[Any]) -> list[tuple[bool, str]]:
    """The diagnosis's findings as `check` prints them: each in full, except that beyond the
    first `SHOWN_PER_KIND` findings of one kind about sensors the rest of that kind (two or
    more) share one line naming the first few (a battery too small for a 30 km map made one
    long CANNOT line per sensor). Cost: O(findings).

    Args:
        findings: `planner_core.model.diagnose.Finding`s, in the diagnosis's order.

    Returns:
        (fatal, printable line) pairs, the shared lines after the others.
    """
    from planner_core.textio import counted, printable

    total: dict[tuple[str, bool], int] = {}
    for f in findings:
        if f.sensor is not None:
            total[(f.kind, f.fatal)] = total.get((f.kind, f.fatal), 0) + 1
    seen: dict[tuple[str, bool], int] = {}
    more: dict[tuple[str, bool], list[str]] = {}  # (kind, fatal) -> sensors beyond the first
    out = []
    for f in findings:
        key = (f.kind, f.fatal)
        seen[key] = seen.get(key, 0) + 1
        if (f.sensor is not None and total[key] > SHOWN_PER_KIND + 1
                and seen[key] > SHOWN_PER_KIND):
            more.setdefault(key, []).append(f.sensor)
            continue
        out.append((bool(f.fatal), printable(f.message)))
    for (kind, fatal), sensors in more.items():
        names = ", ".join(f"'{printable(x)}'" for x in sensors[:SHOWN_PER_KIND])
        out.append((fatal, f"{counted(len(sensors), 'more sensor')} alike ({kind}): {names}"
                           f"{', ...' if len(sensors) > SHOWN_PER_KIND else ''} "
                           "(`lamde-mission check --json` gives each one's line)"))
    return out


def _diagnosis(d: object) -> int:
    """Print the fast feasibility diagnosis `d` (`planner_core.model.diagnose.diagnose`'s);
    1 when something rules every plan out."""
    for fatal, line in finding_lines(d.findings):
        print(f"  {'CANNOT' if fatal else 'note':<6}  {line}")
    if any(f.kind.startswith("C3_") for f in d.findings):
        print("  hint    C3 is the paper's simultaneous uplink; \"radio\": {\"access\": "
              "\"scheduled\"} lets the sensors in range share the bandwidth by time slots")
    if not d.feasible_so_far:
        print(f"{_cannot_what(d, 'this map')} (see CANNOT above)")
        return 1
    return 0


def _cannot_what(d: object, it: str = "it") -> str:
    """'no plan can meet it', or where every CANNOT is the sortie planner's own limit (a
    SORTIE_LIMIT: a plan may exist, the planner does not make it) 'the sortie planner cannot
    plan it' (`it` the words for the map)."""
    if all(f.kind == "SORTIE_LIMIT" for f in d.findings if f.fatal):
        return f"the sortie planner cannot plan {it}"
    return f"no plan can meet {it}"

"""Sortie directories (issue 33): a fleet plan written as one mission per vehicle and sortie,
stored as the autopilot stores it, replayed by the simulator, and a `fleet.json` summary.

`write_sortie_dir` makes each sortie storable (`lamde_mission.storage.storable_plan` on the
sortie's own map: the plan's map with the sortie's depots as start and end and each sensor's
required data set to the sortie's share, so storage raises hover times where the grid or the
rounding would leave a share short), writes `mission-v{vehicle}-s{sortie}.plan` (1-based,
QGroundControl, take-off at its vehicle's pad at the sortie's depot, landing at its pad at its
depot: `planner_core.model.pads`) and `fleet.json` into a
hidden folder beside DIR, verifies everything with `verify_sortie_dir`'s replay and renames the
folder to DIR last (a DIR already there is replaced only then): nothing half-written. A write
killed before its rename leaves its hidden folder; the next write to DIR removes those of
processes gone (`planner_core.atomic.clean_stale_dirs`).

`verify_sortie_dir` replays each mission file of a directory with the simulator on its sortie's
map (start and end at its vehicle's pads at the depots `fleet.json` names) and judges per
sortie C1-C3, C5, ENDS,
CLEAR and ENERGY (`sim.checks.verify`), over the whole plan C4 and MARGIN on the data summed
over the sorties (`sim.sorties.combined_data_verdicts`), and the plan's shape (`FleetCheck.fleet`):
CHAIN (a vehicle's first sortie leaves a depot a vehicle starts from, each later one the depot
the one before it landed at), UAVS (no more vehicles than the map's `fleet.uavs`), FILES (no
mission file in the directory that fleet.json does not list), SEPARATION, LINKS and TIMING
(vehicles together, `sim.fleet_time`), TIMES (fleet.json's take-off times are the plan's
clock), PLACES (fleet.json's take-off and landing places are the missions') and FIGURES
(fleet.json's durations, energies, sensors and totals are the replays'); notes when
fleet.json names another map or a sortie leaves another spot than its pad on this map
(`FleetCheck.notes`). fleet.json is read by `formats.fleet.read_fleet_dir` (unknown fields, a
file listed twice: bad input) and a depot the map lacks refused by `check_sortie_depots`, the
checks `show MAP DIR/` makes too.

fleet.json (the contract of docs/sorties.md):

    {"map": name, "objective": "total" | "makespan",
     "vehicles": [{"vehicle": 1, "makespan_s": s, "sorties": [{"sortie": 1,
        "file": "mission-v1-s1.plan", "depot_start": "home", "depot_end": "home",
        "takeoff_at": {"x": m, "y": m, "lat": deg, "lon": deg, "east_m": m, "north_m": m},
        "landing_at": {...} (the vehicle's pads, east_m and north_m from the depot),
        "takeoff_s": s, "landing_s": s (on the plan's clock: after the first vehicle's
        take-off), "duration_s": s, "energy_wh": Wh, "reserve_left_wh": Wh (battery - energy),
        "above_reserve_wh": Wh (usable - energy), "sensors": ["s01", ...]}]}],
     "total_s": s, "swaps": n, "swap_s": s, "f_total": sum of f + swap_s per swap,
     "depots": {"home": {"x": m, "y": m, "lat": deg, "lon": deg}, ...} (those the sorties use),
     "timing_tolerance_s": s (several vehicles: how far each sortie may take off from its
     time with SEPARATION and LINKS holding, `sim.fleet_time.timing_tolerance`)}

Durations, energies and f_total are the simulator's, on the stored missions (the planner's own
objective, `FleetPlan.total`, is not stored: its model rounds nothing). Cost: one storage pass and
one replay per sortie (O(points x J) each).
"""

from __future__ import annotations

import json
import os
import re
import shutil
from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import cached_property
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from planner_core.atomic import clean_stale_dirs, dir_beside
from planner_core.defaults import MAX_FLEET_SORTIES, MAX_FLEET_VEHICLES
from planner_core.textio import counted, first_few

__all__ = ["FLEET_FILE", "SortieCheck", "FleetCheck", "sortie_dir_refusal", "sortie_dir_of",
           "output_in_sortie_dir", "sortie_file", "sortie_map", "write_sortie_dir",
           "launch_check", "verify_sortie_dir", "check_sortie_depots"]  # fmt: skip

#: the summary file of a sortie directory
FLEET_FILE = "fleet.json"


def sortie_file(vehicle: int, sortie: int) -> str:
    """`mission-v{vehicle}-s{sortie}.plan` (both 1-based).

    Args:
        vehicle: the vehicle's number, 1-based.
        sortie: the sortie's number on that vehicle, 1-based.

    Returns:
        The file name (no folder).
    """
    return f"mission-v{int(vehicle)}-s{int(sortie)}.plan"


#: the names a sortie directory holds (`sortie_file`, `FLEET_FILE`): nothing else is replaced
_SORTIE_NAME = re.compile(r"mission-v[0-9]+-s[0-9]+\.plan")


def looks_like_a_sortie(path: str | Path) -> bool:
    """Whether a mission file is named as a sortie directory names its sorties,
    `mission-v{k}-s{j}.plan` (`sortie_file`).

    Args:
        path: the mission file.

    Returns:
        True for such a name, wherever the file lies.
    """
    return bool(_SORTIE_NAME.fullmatch(Path(path).name))


def sortie_dir_of(path: str | Path) -> Path | None:
    """The sortie directory a mission file is one sortie of, if it is: its folder holds a
    fleet.json that lists it, or holds a fleet.json and the file is named as a sortie
    (`looks_like_a_sortie`).

    Verified alone (`verify MAP FILE`) such a file is judged against the whole map's start,
    end and data, not its own depots and its share of the data (`verify MAP DIR/`).

    Args:
        path: the mission file.

    Returns:
        Its folder when it is a sortie of a sortie directory, else None (also for a file
        named as a sortie in a folder without fleet.json: that folder is no sortie
        directory to verify). A fleet.json that cannot be read is passed over (the name
        alone decides then).
    """
    from lamde_mission.formats.fleet import FleetDirError, read_fleet_dir

    path = Path(path)
    if not (path.parent / FLEET_FILE).is_file():
        return None
    if looks_like_a_sortie(path):
        return path.parent
    try:
        fleet = read_fleet_dir(path.parent)
    except FleetDirError:
        return None
    listed = {s.path.name for veh in fleet.vehicles for s in veh.sorties}
    return path.parent if path.name in listed else None


def sortie_dir_refusal(out_dir: str | Path) -> str | None:
    """Why `out_dir` may not be written (created or replaced) as a sortie directory, or None.

    A sortie directory replaces the folder at its path whole, so only a path that does not
    exist yet, an empty folder or an earlier sortie directory (nothing but `FLEET_FILE` and
    `mission-v{vehicle}-s{sortie}.plan` files) may be written; never a file, a new path named
    like a mission file (`.plan`, `.waypoints`, `.geojson`, `.json`, `.txt`: a folder of that
    name would read as one), the working folder or one above it, nor a folder holding anything
    else (it would be deleted).

    Args:
        out_dir: the directory's path.

    Returns:
        None when it may be written, else the reason in a few words (names the first few
        foreign entries).
    """
    target = Path(out_dir)
    if target.exists() and not target.is_dir():
        return "is a file; a map with a battery or fleet is written as a directory of sorties"
    resolved = target.resolve()
    if resolved == Path.cwd().resolve() or resolved in Path.cwd().resolve().parents:
        return ("is the working folder or one above it; name a new folder for the sorties "
                "(e.g. -o sorties/)")
    if not target.exists():
        from lamde_mission.formats import FORMATS

        if target.suffix.lower() in (*FORMATS, ".json", ".txt"):  # a file's name, not a folder's
            return (f"names a {target.suffix} file; a map with a battery or fleet is written as "
                    "a directory of sorties: name a folder (e.g. -o sorties/)")
        return None
    foreign = sorted(e.name for e in target.iterdir() if not (
        e.is_file() and (e.name == FLEET_FILE or _SORTIE_NAME.fullmatch(e.name))))
    if foreign:
        return (f"holds {first_few(foreign)}, which a sortie directory does not (writing it "
                "replaces the folder whole); name a new or empty folder, or an earlier sortie "
                "directory")
    return None


def output_in_sortie_dir(path: str | Path, out_dir: str | Path) -> str | None:
    """Why another output (`plan --plot`, `show -o`) may not be written at `path`, or None: a
    path inside the sortie directory `out_dir` (links followed) would be deleted by the next
    write of that directory, which replaces it whole, or would make it refuse the folder
    (`sortie_dir_refusal`: a sortie directory holds nothing but fleet.json and its missions).

    Args:
        path: the other output's path.
        out_dir: the sortie directory's path (it need not exist yet).

    Returns:
        None when `path` lies outside `out_dir`, else the reason in a few words, naming both.
    """
    inner, folder = Path(path).resolve(), Path(out_dir).resolve()
    if inner == folder or not inner.is_relative_to(folder):
        return None
    return (f"{path} is inside the sortie directory {out_dir}, "
            "which holds nothing but fleet.json and its missions (plan replaces it whole, and "
            "refuses a folder holding anything else); write it beside that folder")


def sortie_map(
    m: Any, start: str, end: str, required: np.ndarray | None = None, name: str | None = None,
    pads: tuple[int, int] = (0, 0),
) -> Any:
    """The map one sortie is stored and replayed on: `m` with start and end at pads
    `pads` (indices into `Map.pads_for`; index 0, pad 1, the depot itself; which vehicle uses
    which: `planner_core.model.pads.pad_ranks`) of the depots named `start` and `end`
    (`planner_core.fleet.FleetSettings` names: the map's depots, or "home" and "end"),
    sensors' required data `required` (J,) Mbit (default 0: the whole plan's C4 is judged
    over all sorties), the battery kept (ENERGY), the fleet left out.

    Args:
        m: the whole map (with its battery or fleet).
        start: the depot the sortie takes off from.
        end: the depot it lands at.
        required: (J,) Mbit per sensor (user units, before the data margin); None: zeros.
        name: the sortie map's name (default m's).
        pads: (pad at `start`, pad at `end`), 0-based (beyond the map's `fleet.uavs`: the
            layout for that many, `Map.pads_for`; the UAVS verdict fails such a plan).

    Returns:
        The loaded sortie `Map`.

    Raises:
        ValueError: an unknown depot name.
    """
    from planner_core.fleet import FleetSettings, sortie_map_dict
    from planner_core.model.mapio import load_map

    st = FleetSettings.from_map(m)
    names = list(st.depot_names)
    for d in (start, end):
        if d not in names:
            raise ValueError(f"depot: unknown depot '{d}' (the map's are "
                             f"{', '.join(names)})")  # fmt: skip
    req = np.zeros(len(m.sensor_ids)) if required is None else np.asarray(required, float)
    layout = m.pads_for(max(int(m.uavs), int(max(pads)) + 1))
    a, b = (layout[int(k), names.index(d)] for k, d in zip(pads, (start, end), strict=True))
    return load_map(sortie_map_dict(m, a, b, req, name=name))


@dataclass(frozen=True)
class SortieCheck:
    """One sortie's replay: vehicle, sortie (1-based), file name, depots, the simulator's
    timeline and verdicts, the sensors it collects data from."""

    vehicle: int
    sortie: int
    file: str
    depot_start: str
    depot_end: str
    timeline: Any
    verdicts: Any
    sensors: tuple[str, ...]

    @property
    def duration_s(self) -> float:
        """Take-off to landing, s (the sim's).

        Returns:
            The timeline's t_total, s.
        """
        return float(self.timeline.totals.t_total)

    @property
    def collected_mbit(self) -> dict[str, float]:
        """What the sortie collects from each sensor it serves (`sensors`), by id: its share
        of the data that the whole plan's C4 and MARGIN judge.

        Returns:
            {sensor id: Mbit}, in the map's sensor order.
        """
        q = self.timeline.collected
        ids = list(self.timeline.sensor_ids)
        return {sid: float(q[ids.index(sid)]) for sid in self.sensors}

    @property
    def takeoff_xy(self) -> np.ndarray:
        """Where the replay takes off (the stored mission's take-off), local m.

        Returns:
            (2,) m.
        """
        return np.asarray(self.timeline.xy[0], dtype=float)

    @property
    def landing_xy(self) -> np.ndarray:
        """Where the replay lands (the stored mission's landing), local m.

        Returns:
            (2,) m.
        """
        return np.asarray(self.timeline.xy[-1], dtype=float)


#: m: two vehicles whose missions take off or land this near each other share one spot
SHARED_SPOT_M = 1.0


#: MAVLink MAV_CMD_NAV_TAKEOFF and MAV_CMD_NAV_LAND
NAV_TAKEOFF, NAV_LAND = 22, 21


def mission_stands(path: str | Path) -> list[tuple[int, float, float]]:
    """Where a mission file's vehicle stands on the ground: (command, lat, lon) of each
    NAV_TAKEOFF and NAV_LAND item that gives a position, in the file's order.

    Args:
        path: the mission file.

    Returns:
        [(NAV_TAKEOFF or NAV_LAND, lat deg, lon deg)]; empty for an unreadable file (whoever
        sends or verifies it names what is wrong with it).
    """
    from lamde_mission.formats import MissionFileError, read_mission

    try:
        items, _ = read_mission(path)
    except MissionFileError:
        return []
    return [(int(it.command), float(it.x), float(it.y)) for it in items
            if it.command in (NAV_TAKEOFF, NAV_LAND) and (it.x or it.y)]  # fmt: skip


def depot_xy(m: Any, name: str | None) -> np.ndarray | None:
    """A sortie site's position by name (`Map.sortie_sites`).

    Args:
        m: the map.
        name: the depot's name.

    Returns:
        (2,) local m, or None when the map has no such site.
    """
    names, sites, _ = m.sortie_sites
    return sites[list(names).index(name)] if name in names else None


def depot_positions(m: Any, names: Sequence[str] | None = None) -> dict[str, dict[str, float]]:
    """{depot: {"x", "y", "lat", "lon"}} of the map's sortie sites (those named in `names`,
    in the map's order; all by default).

    Args:
        m: the map (with an origin).
        names: the depots wanted (unknown ones left out); None: every site.

    Returns:
        The positions (`_position`).
    """
    known, sites, _ = m.sortie_sites
    return {n: _position(m, xy) for n, xy in zip(known, sites, strict=True)
            if names is None or n in names}  # fmt: skip


def _stands(fleet: Any) -> list[tuple[int, float, float]]:
    """Every (vehicle, lat, lon) a directory's missions take off from or land at
    (`mission_stands` of the mission files fleet.json lists)."""
    return [(v.vehicle, lat, lon) for v in fleet.vehicles
            for s in v.sorties for _, lat, lon in mission_stands(s.path)]  # fmt: skip


def shared_spots(fleet: Any) -> str | None:
    """Two vehicles of a sortie directory that take off or land at one spot (within
    `SHARED_SPOT_M`), as a directory planned before each vehicle had its own pad has them:
    one would land on, or take off beside, the other standing there. Judged from the mission
    files alone (no map needed); None when every vehicle has spots of its own. Cost: O(S^2)
    for S take-offs and landings (2 per sortie, at most 2,000).

    Args:
        fleet: the sortie directory as read (`formats.fleet.read_fleet_dir`: the caller has
            read fleet.json already).

    Returns:
        The sentence naming the two vehicles and the spot, or None.
    """
    from lamde_mission.geo import latlon_to_enu

    stands = _stands(fleet)
    if not stands:
        return None
    origin = (stands[0][1], stands[0][2], 0.0)
    xy = np.array([latlon_to_enu(lat, lon, origin) for _, lat, lon in stands], dtype=float)
    who = np.array([v for v, _, _ in stands])
    d = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1])
    bad = np.argwhere((d < SHARED_SPOT_M) & (who[:, None] < who[None, :]))
    if not len(bad):
        return None
    a, b = bad[0]
    return (f"vehicles {who[a]} and {who[b]} both take off or land at lat {stands[a][1]:.7f}, "
            f"lon {stands[a][2]:.7f}: one would land on, or take off beside, the other "
            "standing there (a directory planned before each vehicle had its own pad: plan it "
            "again)")


def pad_words(m: Any, depot: str, xy: np.ndarray) -> str:
    """A depot's name and, when a sortie takes off or lands beside it (its vehicle's own pad,
    `Map.vehicle_pads`), where, as a crew paces it from the depot: "north" or "north, pad 35 m
    N, 35 m E" (`planner_core.model.pads.offset_words`).

    Args:
        m: the plan's map.
        depot: the depot's name (one of the map's sortie sites).
        xy: (2,) the take-off or landing position, local m.

    Returns:
        The words (printable).
    """
    from planner_core.model.pads import offset_words
    from planner_core.textio import printable

    at = depot_xy(m, depot)
    if at is None:
        return printable(depot)
    dx, dy = np.asarray(xy, dtype=float) - at
    if float(np.hypot(dx, dy)) < 0.5:
        return printable(depot)
    return f"{printable(depot)}, pad {offset_words(dx, dy)}"


def _position(m: Any, xy: np.ndarray, depot: str | None = None) -> dict[str, float]:
    """{"x", "y" (local m), "lat", "lon" (WGS84 degrees, 1e-7)} of a point of map m, and with
    a depot's name its "east_m", "north_m" from that depot (a pad, as a crew lays it out)."""
    from lamde_mission.geo import enu_to_latlon

    lat, lon = enu_to_latlon(xy[0], xy[1], m)
    out = {"x": round(float(xy[0]), 3), "y": round(float(xy[1]), 3),
           "lat": round(float(lat), 7), "lon": round(float(lon), 7)}  # fmt: skip
    at = depot_xy(m, depot)
    if at is not None:
        dx, dy = np.asarray(xy, dtype=float) - at
        out.update(east_m=round(float(dx), 2) + 0.0, north_m=round(float(dy), 2) + 0.0)
    return out


@dataclass(frozen=True)
class FleetCheck:
    """A whole plan's verdicts: per sortie (`sorties`), `combined` (C4, MARGIN over the sum of
    the sorties' data) and `fleet` (the plan's shape: CHAIN, UAVS, FILES; module docstring);
    `swap_s` for the spans; `notes`, lines that judge nothing (another map's name)."""

    sorties: tuple[SortieCheck, ...]
    combined: tuple[Any, ...]
    swap_s: float
    fleet: tuple[Any, ...] = ()
    notes: tuple[str, ...] = ()
    #: each vehicle's launch, s after the first's take-off (`lamde_mission.launches`)
    launches: tuple[float, ...] = ()
    #: s: how far each sortie may take off from its time with SEPARATION and LINKS holding
    #: (`sim.fleet_time.timing_tolerance`); None with one vehicle flying
    timing_tolerance_s: float | None = None

    @property
    def passed(self) -> bool:
        """Every sortie's verdicts (no C4 or MARGIN: `_check`), the combined ones and the
        plan's shape.

        Returns:
            True when all of them passed.
        """
        own = all(v.passed for s in self.sorties for v in s.verdicts)
        return own and all(v.passed for v in (*self.combined, *self.fleet))

    def failed(self) -> list[str]:
        """Lines naming each failed verdict (sortie and check).

        Returns:
            "v{vehicle} s{sortie} NAME: detail" per failed sortie verdict, then "whole plan
            NAME: detail", then "fleet NAME: detail".
        """
        out = [
            f"v{s.vehicle} s{s.sortie} {v.name}: {v.detail}"
            for s in self.sorties
            for v in s.verdicts
            if not v.passed
        ]
        out += [f"whole plan {v.name}: {v.detail}" for v in self.combined if not v.passed]
        out += [f"fleet {v.name}: {v.detail}" for v in self.fleet if not v.passed]
        return out

    def vehicles(self) -> dict[int, list[SortieCheck]]:
        """Sorties by vehicle, in order.

        Returns:
            {vehicle: [its `SortieCheck`s in the order of `sorties`]}, vehicles in order of
            first appearance.
        """
        out: dict[int, list[SortieCheck]] = {}
        for s in self.sorties:
            out.setdefault(s.vehicle, []).append(s)
        return out

    def launch(self, vehicle: int) -> float:
        """Vehicle's launch, s after the first vehicle's take-off (0 without launches).

        Args:
            vehicle: the vehicle's number, 1-based.

        Returns:
            `launches[vehicle - 1]`, s; 0.0 when `launches` does not reach it.
        """
        return float(self.launches[vehicle - 1]) if len(self.launches) >= vehicle else 0.0

    @cached_property
    def _clock(self) -> dict[tuple[int, int], float]:
        """{(vehicle, its sortie's number, 1-based): take-off s}, in one pass over `sorties`:
        the vehicle's launch, its earlier sorties' durations, `swap_s` per earlier sortie."""
        done: dict[int, tuple[int, float]] = {}  # vehicle -> (sorties so far, their seconds)
        out = {}
        for s in self.sorties:
            n, flown = done.get(s.vehicle, (0, 0.0))
            out[(s.vehicle, n + 1)] = self.launch(s.vehicle) + flown + self.swap_s * n
            done[s.vehicle] = (n + 1, flown + s.duration_s)
        return out

    def takeoff(self, vehicle: int, sortie: int) -> float:
        """When a sortie takes off, on the plan's clock: the vehicle's launch, then its earlier
        sorties back to back with `swap_s` on the ground after each (the timing SEPARATION and
        LINKS are judged at; `sim.fleet_time.track` lays a vehicle out the same way).

        Args:
            vehicle: the vehicle's number, 1-based.
            sortie: the sortie's number on that vehicle, 1-based.

        Returns:
            Seconds after the first vehicle's take-off.

        Raises:
            KeyError: the vehicle flies no sortie here.
            IndexError: the vehicle flies fewer sorties.
        """
        got = self._clock.get((vehicle, sortie))
        if got is None:
            ss = self.vehicles()[vehicle]  # KeyError: no sortie of this vehicle
            raise IndexError(f"vehicle {vehicle} flies {len(ss)} sorties, not {sortie}")
        return got

    def takeoffs(self) -> list[float]:
        """Every sortie's take-off (`takeoff`), in the order of `sorties`.

        Returns:
            Seconds after the first vehicle's take-off, one per sortie.
        """
        return list(self._clock.values())

    def makespan(self, vehicle: int) -> float:
        """From the first vehicle's take-off to this vehicle's last landing: its launch, its
        sorties and swaps (s).

        Args:
            vehicle: the vehicle's number, 1-based.

        Returns:
            The last sortie's take-off (`takeoff`) + its duration, s.

        Raises:
            KeyError: the vehicle flies no sortie here.
        """
        ss = self.vehicles()[vehicle]
        return self.takeoff(vehicle, len(ss)) + ss[-1].duration_s

    @property
    def fleet_makespan(self) -> tuple[float, int]:
        """The fleet's makespan: from the first vehicle's take-off to the last landing of any
        vehicle, launches included (what the makespan goal minimises, as flown), and the
        vehicle that lands last (the lowest number of a tie).

        Returns:
            (seconds, the vehicle's number); (0.0, 0) without sorties.
        """
        got = [(self.makespan(v), -v) for v in self.vehicles()]
        if not got:
            return 0.0, 0
        s, v = max(got)
        return s, -v

    @property
    def total_s(self) -> float:
        """All sorties' durations plus swap_s per swap (s); the launches' waits not counted.

        Returns:
            The total, s.
        """
        return sum(s.duration_s for s in self.sorties) + self.swap_s * self.swaps

    @property
    def f_total(self) -> float:
        """The objective "total" on the replays: the paper's f of each stored sortie as the
        simulator flies it, summed, plus swap_s per swap.

        Returns:
            The sum, s.
        """
        return sum(float(s.timeline.totals.f) for s in self.sorties) + self.swap_s * self.swaps

    @property
    def swaps(self) -> int:
        """Battery swaps: each vehicle's sorties after its first.

        Returns:
            The count over all vehicles.
        """
        return sum(len(ss) - 1 for ss in self.vehicles().values())


def _served(tl: Any, req: np.ndarray) -> tuple[str, ...]:
    """Sensors a replay collects at least 0.1 % of their requirement from."""
    q = tl.collected
    ids = tl.sensor_ids
    return tuple(ids[j] for j in range(len(ids)) if q[j] > 1e-3 * max(float(req[j]), 1e-9))


def _sortie_verdicts(vd: Any) -> Any:
    """A sortie's own verdicts: `sim.checks.verify` on its sortie map less C4 and MARGIN. The
    sortie map requires no data (`sortie_map`: a sensor may be served by several sorties), so
    they would judge nothing ("0 of 0 Mbit" of some sensor it does not serve, "no data
    required"); the whole plan's C4 and MARGIN judge the data of all sorties together
    (`FleetCheck.combined`), and `SortieCheck.collected_mbit` says what the sortie adds.

    Args:
        vd: the sortie's `sim.checks.Verdicts`.

    Returns:
        The same verdicts without C4 and MARGIN, and without data margins (each +inf).
    """
    return replace(vd, items=tuple(v for v in vd.items if v.name not in ("C4", "MARGIN")),
                   data_margins={})


def _chain_verdict(m: Any, rows: list[tuple[int, int, str, str, str, list[Any]]]) -> Any:
    """CHAIN: each vehicle's first sortie leaves a depot a vehicle starts from
    (`FleetSettings.start_depots`) and each later one the depot the sortie before it landed at
    (a vehicle takes off where it stands, as `FleetPlan.chained` asks of a plan).

    Args:
        m: the plan's map.
        rows: (vehicle, sortie, file, depot_start, depot_end, items), each vehicle's sorties
            in flying order; depots known to the map.

    Returns:
        The `sim.checks.Verdict`: its margin minus the largest jump in m (0: none), its detail
        naming each vehicle, sortie and both depots with their distance.
    """
    from planner_core.fleet import FleetSettings
    from sim.checks import Verdict

    st = FleetSettings.from_map(m)
    names, xy = list(st.depot_names), np.asarray(st.depots, dtype=float)

    def apart(a: str, b: str) -> float:
        return float(np.hypot(*(xy[names.index(a)] - xy[names.index(b)])))

    starts = [names[i] for i in st.start_depots]
    jumps: list[tuple[float, str]] = []
    for i, (v, k, _f, a, _b, _items) in enumerate(rows):
        before = rows[i - 1] if i and rows[i - 1][0] == v else None
        if before is None and a not in starts:
            d = min(apart(a, x) for x in starts)
            jumps.append((d, f"vehicle {v} sortie {k} takes off at '{a}', not a depot a vehicle "
                             f"starts from ({', '.join(starts)}; {d:.0f} m away)"))  # fmt: skip
        elif before is not None and before[4] != a:
            d = apart(a, before[4])
            jumps.append((d, f"vehicle {v} sortie {k} takes off at '{a}' but its sortie "
                             f"{before[1]} landed at '{before[4]}', {d:.0f} m away"))  # fmt: skip
    title = "each sortie takes off where its vehicle stands"
    if not jumps:
        return Verdict("CHAIN", title, True, 0.0, "m",
                       "every vehicle takes off where it landed")  # fmt: skip
    return Verdict("CHAIN", title, False, -max(d for d, _ in jumps), "m",
                   "; ".join(line for _, line in jumps))  # fmt: skip


def _uavs_verdict(m: Any, vehicles: int) -> Any:
    """UAVS: the plan flies at most the map's `fleet.uavs` vehicles (1 without a fleet).

    Args:
        m: the plan's map.
        vehicles: the plan's vehicles (those fleet.json lists).

    Returns:
        The `sim.checks.Verdict`: its margin the vehicles to spare (negative: too many).
    """
    from sim.checks import Verdict

    uavs = int(m.uavs)
    detail = f"fleet.json plans {counted(vehicles, 'vehicle')}, the map's fleet.uavs is {uavs}"
    return Verdict("UAVS", "vehicles <= fleet.uavs", vehicles <= uavs, float(uavs - vehicles),
                   "vehicles", detail)  # fmt: skip


def _files_verdict(directory: Path, listed: list[str]) -> Any:
    """FILES: the directory holds no mission file (`.plan`, `.waypoints`, `.geojson`) that
    fleet.json does not list: an operator loading the files by name would fly a stale one.

    Args:
        directory: the sortie directory.
        listed: the file names fleet.json lists.

    Returns:
        The `sim.checks.Verdict`: its margin minus the stray files' count, its detail naming
        them.
    """
    from lamde_mission.formats import FORMATS
    from sim.checks import Verdict

    stray = sorted(e.name for e in Path(directory).iterdir()
                   if e.is_file() and e.suffix.lower() in FORMATS
                   and e.name not in listed)  # fmt: skip
    title = "no mission file fleet.json does not list"
    if not stray:
        return Verdict("FILES", title, True, 0.0, "files",
                       f"the {len(listed)} mission files are those fleet.json lists")  # fmt: skip
    return Verdict("FILES", title, False, -float(len(stray)), "files",
                   f"{', '.join(stray)} in {Path(directory).name}/ but not listed in "
                   f"{FLEET_FILE} (stale: an operator loading the files by name would fly "
                   "it; remove it)")  # fmt: skip


def _check(
    m: Any, rows: list[tuple[int, int, str, str, str, list[Any]]], vehicles: int,
    directory: Path | None, launches: list[float] | None = None,
    speed_limits: dict[int, float] | None = None,
) -> FleetCheck:
    """Replay each (vehicle, sortie, file, depot_start, depot_end, items) on its sortie map;
    judge the whole plan's data, its shape (`vehicles`: how many the plan lists; the mission
    files in `directory`, None: none to judge) and its vehicles in the air together
    (SEPARATION, LINKS at each vehicle's launch: `launches[k - 1]` for vehicle k, as
    fleet.json lists them; None: staggered by `lamde_mission.launches.stagger`, as a plan is
    written). Both stagger and
    SEPARATION keep the map's `fleet.separation_m` (`m.separation_m`, metres). `speed_limits`:
    {vehicle: m/s}, each such vehicle's sorties flown at most at its own speed limit
    (`sim.replay`'s speed_limit), on the same launch times."""
    from lamde_mission.launches import stagger
    from planner_core.model.pads import pad_ranks
    from sim import replay, verify
    from sim.fleet_time import fleet_time_verdicts, track
    from sim.sorties import combined_data_verdicts

    out = []
    req = np.asarray(m.required_data, dtype=float)
    rank = pad_ranks((v, d) for v, _k, _f, a, b, _i in rows for d in (a, b))
    for v, k, f, a, b, items in rows:
        sm = sortie_map(m, a, b, name=f"{m.name} v{v} s{k}", pads=(rank[(v, a)], rank[(v, b)]))
        tl = replay(items, sm, speed_limit=(speed_limits or {}).get(v))
        ends = (f"its pad at '{a}'", f"its pad at '{b}'")  # the sortie map's start and end
        out.append(SortieCheck(v, k, f, a, b, tl, _sortie_verdicts(verify(tl, sm, end_names=ends)),
                               _served(tl, req)))
    combined = combined_data_verdicts([s.timeline for s in out], m)
    shape = (_chain_verdict(m, rows), _uavs_verdict(m, vehicles),
             *(() if directory is None else (_files_verdict(directory, [r[2] for r in rows]),)))
    by_vehicle: dict[int, list[Any]] = {}
    for s in out:
        by_vehicle.setdefault(s.vehicle, []).append(s.timeline)
    flying = sorted(by_vehicle)  # vehicles with a sortie (a vehicle may have none)
    sep = float(m.separation_m)  # m, the map's fleet.separation_m
    at: dict[int, float] = {v: 0.0 for v in flying}
    placed = []
    if len(flying) > 1:  # one vehicle alone meets nothing in the air: no tracks to build
        tracks = [track(by_vehicle[v], float(m.swap_s)) for v in flying]
        given = stagger(tracks, separation=sep, tolerance=m.launch_tolerance_s) \
            if launches is None else [
            float(launches[v - 1]) if v <= len(launches) else 0.0 for v in flying]
        at = dict(zip(flying, given, strict=True))
        placed = [x.at(t) for x, t in zip(tracks, given, strict=True)]
    air = fleet_time_verdicts(placed, tuple(m.sensor_ids), separation=sep,
                              numbers=flying if placed else None)
    check = FleetCheck(tuple(out), tuple(combined), float(m.swap_s), (*shape, *air),
                       launches=tuple(at.get(v, 0.0) for v in range(1, max(flying, default=0)
                                                                    + 1)))
    if len(flying) < 2:
        return check
    from sim.checks import Verdict
    from sim.fleet_time import timing_tolerance

    slack = timing_tolerance(placed, separation=sep)
    want = float(m.launch_tolerance_s)
    asks = f"the map's fleet.launch_tolerance_s asks {want:g} s"
    if slack <= 0.0:  # said as a failure, not as a claim read before its FAIL
        said = f"SEPARATION or LINKS fail unless every sortie takes off on its time ({asks})"
    else:
        said = (f"SEPARATION and LINKS hold {'only ' if slack < want else ''}while each sortie "
                f"takes off within +-{slack:g} s of its time ({asks})")
    timing = Verdict("TIMING", f"take-offs may be {want:g} s off", bool(slack >= want),
                     slack - want, "s", said)
    return replace(check, fleet=(*check.fleet, timing), timing_tolerance_s=slack)


def check_sortie_depots(fleet: Any, m: Any) -> None:
    """Every sortie of a sortie directory names the depot it takes off at and the one it lands
    at (`depot_start`, `depot_end`), and map `m` has both: a sortie is replayed, and drawn,
    from its depot to its depot. The one check `verify MAP DIR/`, `upload DIR/ --fleet --map
    MAP` and `show MAP DIR/` make (exit 2 for each). Cost: O(sorties x depots).

    Args:
        fleet: the directory as read (`formats.fleet.read_fleet_dir`).
        m: the map it is verified or drawn on.

    Raises:
        ValueError: one line naming fleet.json, the vehicle, sortie and file, the depot, the
            map's depots and the map the directory was planned on (`_unknown_depot`); or the
            field of a sortie without a depot.
    """
    from planner_core.fleet import FleetSettings

    summary = fleet.path / FLEET_FILE
    depots = FleetSettings.from_map(m).depot_names
    for vi, veh in enumerate(fleet.vehicles):
        for si, s in enumerate(veh.sorties):
            for which, depot in (("depot_start", s.depot_start), ("depot_end", s.depot_end)):
                if depot is None:  # the replay flies each sortie from its depot to its depot
                    raise ValueError(f"{summary}: vehicles[{vi}].sorties[{si}].{which}: missing "
                                     "(a depot's name of the map)")  # fmt: skip
                if depot not in depots:
                    raise ValueError(_unknown_depot(fleet, m.name, depots, veh.vehicle, s,
                                                    which, depot))  # fmt: skip


def verify_sortie_dir(m: Any, path: str | Path,
                      speed_limits: dict[int, float] | None = None) -> FleetCheck:
    """Replay and judge the sortie directory `path` on map `m` (module docstring).

    Args:
        m: the map the plan was made for (with its origin).
        path: the directory holding fleet.json and the mission files.
        speed_limits: {vehicle (1-based): its own horizontal speed limit, m/s}: that
            vehicle's sorties flown at most at it (as PX4 flies a mission above
            MPC_XY_VEL_MAX), at the launch times fleet.json gives; None: as planned (only
            then is FIGURES judged: fleet.json's durations and energies are the planned
            speeds').

    Returns:
        The `FleetCheck` (with a note when fleet.json names another map than `m`).

    Raises:
        ValueError: one line naming the file and the problem (no fleet.json or a bad field
            of it, `formats.fleet.read_fleet_dir`; a missing or unreadable mission file; an
            unknown depot, `check_sortie_depots`).
    """
    from lamde_mission.formats import MissionFileError, load_mission_items
    from lamde_mission.formats.fleet import read_fleet_dir

    fleet = read_fleet_dir(path)  # FleetDirError (a ValueError): the file and field by name
    check_sortie_depots(fleet, m)
    rows = []
    for veh in fleet.vehicles:
        for s in veh.sorties:
            try:
                items, _ = load_mission_items(str(s.path), m)
            except MissionFileError as exc:
                raise ValueError(f"{s.path}: {exc}") from None
            rows.append((veh.vehicle, s.sortie, s.path.name, s.depot_start, s.depot_end, items))
    check = _check(m, rows, len(fleet.vehicles), fleet.path,
                   [veh.launch_s for veh in fleet.vehicles], speed_limits)
    given = [(veh.vehicle, s.sortie, s.takeoff_s) for veh in fleet.vehicles for s in veh.sorties]
    times = (_times_verdict(given, check.takeoffs(), fleet.swap_s, float(m.swap_s))
             if not speed_limits else _times_at_limits(given, check.takeoffs()))
    figures = () if speed_limits else (_figures_verdict(check, fleet),)
    check = replace(check, fleet=(*check.fleet, times, _places_verdict(m, check, fleet),
                                  *figures))
    notes = [n for n in (_far_note(m, check), fleet.map_note(m.name, "verified"),
                         _battery_note(m, fleet), _pads_note(m, check)) if n]  # fmt: skip
    return replace(check, notes=tuple(notes)) if notes else check


def _battery_note(m: Any, fleet: Any) -> str | None:
    """A note when fleet.json gives the energies of sorties planned with a battery and the map
    verified on has none: ENERGY is not judged, and those energies (what `upload --fleet`
    reports without a map) no longer say what the sorties may spend. O(sorties).

    Args:
        m: the map verified on.
        fleet: the directory's fleet.json (`formats.fleet.read_fleet_dir`).

    Returns:
        One line naming the directory, the sorties with an energy and the first of them, or
        None when the map has a battery or fleet.json gives no energy.
    """
    from planner_core.textio import printable

    if m.has_battery:
        return None
    planned = [s for v in fleet.vehicles for s in v.sorties if s.energy_wh is not None]
    if not planned:
        return None
    first = planned[0]
    which = (f"{first.path.name}: {first.energy_wh:.2f} Wh" if len(planned) == 1 else
             f"{counted(len(planned), 'sortie')}, e.g. {first.path.name}: "
             f"{first.energy_wh:.2f} Wh")  # fmt: skip
    return printable(
        f"{fleet.path}: planned with a battery (its energies: {which}), verified on map "
        f"'{m.name}', which has none: ENERGY is not judged, and fleet.json's energies and "
        "reserves no longer apply (verify on the map with its uav.battery or uav.endurance_s "
        "to judge them)")


#: sensors a FIGURES line names by id where fleet.json and the replay differ (then a count)
SENSORS_NAMED = 3


def _sensor_words(ids: Sequence[str]) -> str:
    """'S1', 'S2' and 2 more: the first `SENSORS_NAMED` ids quoted, then a count."""
    from planner_core.textio import printable

    return first_few([f"'{printable(x)}'" for x in ids[:SENSORS_NAMED]], SENSORS_NAMED,
                     len(ids))


def _figures_verdict(check: FleetCheck, fleet: Any) -> Any:
    """FIGURES: what fleet.json states beside the times and places (what the crew reads) is what
    the replays find: each sortie's `duration_s`, `landing_s`, `energy_wh`, `reserve_left_wh`,
    `above_reserve_wh` (null where the map has no battery) and `sensors`, each vehicle's
    `makespan_s`, and `total_s`, `swaps`, `f_total` and `timing_tolerance_s`; seconds to
    `formats.fleet.CLOCK_TOL_S`, energies to `ENERGY_TOL_WH`, the sensors as sets. A figure
    fleet.json does not give is not judged (a directory written before it was recorded), nor
    are the energies on a map without a battery (`_battery_note`'s line says why). A
    hand-edited energy, duration or list of sensors passed verify before.

    Args:
        check: the replays, in fleet.json's order of sorties (with TIMING's tolerance).
        fleet: the directory as read (`formats.fleet.read_fleet_dir`).

    Returns:
        The `sim.checks.Verdict`: its margin minus the figures that differ (0: none), its
        detail naming the first (the vehicle, sortie and field, both values) and the count.
        Cost: O(sorties x sensors).
    """
    from lamde_mission.formats.fleet import CLOCK_TOL_S, ENERGY_TOL_WH
    from sim.checks import Verdict

    off: list[str] = []
    unjudged: set[str] = set()
    n = 0

    def judge(who: str, key: str, given: float | None, found: float | None, unit: str,
              tol: float, null: bool = False) -> None:
        nonlocal n
        if given is None and not null:
            return
        if found is None and unit == "Wh":
            unjudged.add(key)  # the map verified on has no battery (`_battery_note` says so)
            return
        n += 1
        if given is None or found is None:
            if given is not None or found is not None:
                shown = "null" if given is None else f"{given:g} {unit}"
                what = "no battery on this map" if found is None else f"{found:.3f} {unit}"
                off.append(f"{who}{key} {shown} in fleet.json, replayed {what}")
            return
        if abs(given - found) > tol:
            said, got = ((f"{given:g} {unit}", f"{found:.3f} {unit}") if unit
                         else (f"{given:g}", f"{found:g}"))  # fmt: skip
            off.append(f"{who}{key} {said} in fleet.json, replayed {got}")

    sorties = [s for v in fleet.vehicles for s in v.sorties]
    for sc, s, at in zip(check.sorties, sorties, check.takeoffs(), strict=True):
        who, vd = f"vehicle {sc.vehicle} sortie {sc.sortie} ", sc.verdicts
        judge(who, "duration_s", s.duration_s, sc.duration_s, "s", CLOCK_TOL_S)
        judge(who, "landing_s", s.landing_s, at + sc.duration_s, "s", CLOCK_TOL_S)
        judge(who, "energy_wh", s.energy_wh, vd.energy_wh, "Wh", ENERGY_TOL_WH, s.no_battery)
        judge(who, "reserve_left_wh", s.reserve_left_wh, vd.reserve_left_wh, "Wh", ENERGY_TOL_WH)
        judge(who, "above_reserve_wh", s.above_reserve_wh, vd.above_reserve_wh, "Wh",
              ENERGY_TOL_WH)
        n += 1
        listed, served = set(s.sensors), set(sc.sensors)
        if listed != served:
            gone = [x for x in sc.sensors if x not in listed]
            more = [x for x in s.sensors if x not in served]
            off.append(f"{who}sensors in fleet.json " + " and ".join(w for w in (
                f"leave out {_sensor_words(gone)}, which the replay collects from" if gone
                else "", f"list {_sensor_words(more)}, which the replay collects nothing from"
                if more else "") if w))  # fmt: skip
    for v in fleet.vehicles:
        if v.sorties:
            judge(f"vehicle {v.vehicle} ", "makespan_s", v.makespan_s, check.makespan(v.vehicle),
                  "s", CLOCK_TOL_S)
    judge("", "total_s", fleet.total_s, check.total_s, "s", CLOCK_TOL_S)
    judge("", "swaps", None if fleet.swaps is None else float(fleet.swaps), float(check.swaps),
          "", 0.5)
    judge("", "f_total", fleet.f_total, check.f_total, "s", CLOCK_TOL_S)
    if fleet.timing_tolerance_s is not None or check.timing_tolerance_s is None:
        judge("", "timing_tolerance_s", fleet.timing_tolerance_s, check.timing_tolerance_s, "s",
              CLOCK_TOL_S)
    title = "fleet.json's durations, energies and sensors are the replays'"
    skipped = (f" (not its {', '.join(sorted(unjudged))}: the map has no battery)" if unjudged
               else "")  # fmt: skip
    if not off:
        return Verdict("FIGURES", title, True, 0.0, "figures",
                       f"the {n} figures fleet.json gives are the replays'{skipped}")
    more = f"; {len(off)} figures differ" if len(off) > 1 else ""
    return Verdict("FIGURES", title, False, -float(len(off)), "figures",
                   f"{off[0]}{more}: the crew reads fleet.json's figures, the vehicles fly the "
                   "missions")


def _far_note(m: Any, check: FleetCheck) -> str | None:
    """A note when a sortie's mission lies far from the map's area (`sim.replay.far_from_area`:
    the wrong map, or another origin), naming the first such file and counting the others.

    Args:
        m: the map verified on.
        check: the replayed directory.

    Returns:
        One line, or None when every sortie flies near the map's area.
    """
    from sim.replay import far_from_area

    far = [(s.file, n) for s in check.sorties
           if (n := far_from_area(s.timeline.route, m)) is not None]  # fmt: skip
    if not far:
        return None
    more = f" (and {counted(len(far) - 1, 'other sortie')})" if len(far) > 1 else ""
    return f"{far[0][0]}{more}: {far[0][1]}"


def _places_verdict(m: Any, check: FleetCheck, fleet: Any) -> Any:
    """PLACES: the take-off and landing places fleet.json gives (each vehicle's pad, which
    `upload --fleet` prints for the crew) are the missions' own, and the depots it names are
    the map's. A hand-edited place (two vehicles told to stand on one spot) fails it.

    Args:
        m: the map verified on.
        check: the replays, in fleet.json's order of sorties.
        fleet: the directory as read (`formats.fleet.read_fleet_dir`): per sortie its
            `takeoff_at` and `landing_at` (lat, lon; east_m, north_m from the depot; x, y),
            and its `depots` (lat, lon; x, y), each judged where fleet.json gives it.

    Returns:
        The `sim.checks.Verdict` (its margin minus the largest distance beyond
        `formats.fleet.PLACE_TOL_M`).
    """
    from lamde_mission.formats.fleet import PLACE_TOL_M
    from lamde_mission.geo import latlon_to_enu
    from sim.checks import Verdict

    title = "fleet.json's take-off and landing places are the missions'"
    off: list[tuple[float, str]] = []
    n = 0
    names = m.sortie_sites[0]
    given_sorties = [s for v in fleet.vehicles for s in v.sorties]
    for sc, s in zip(check.sorties, given_sorties, strict=True):
        for what, given, paced, local, xy, depot in (
                ("takes off", s.takeoff_at, s.takeoff_offset, s.takeoff_xy, sc.takeoff_xy,
                 sc.depot_start),
                ("lands", s.landing_at, s.landing_offset, s.landing_xy, sc.landing_xy,
                 sc.depot_end)):  # fmt: skip
            if given is not None:
                n += 1
                x, y = latlon_to_enu(given[0], given[1], m)
                d = float(np.hypot(float(x) - xy[0], float(y) - xy[1]))
                if d > PLACE_TOL_M:
                    off.append((d, f"vehicle {sc.vehicle} sortie {sc.sortie} {what} at lat "
                                   f"{given[0]:.7f}, lon {given[1]:.7f} in fleet.json, {d:.1f} "
                                   f"m from where its mission {what}"))  # fmt: skip
            if local is not None:
                n += 1
                d = float(np.hypot(local[0] - xy[0], local[1] - xy[1]))
                if d > PLACE_TOL_M:
                    off.append((d, f"vehicle {sc.vehicle} sortie {sc.sortie} {what} at x "
                                   f"{local[0]:g}, y {local[1]:g} m in fleet.json, {d:.1f} m "
                                   f"from where its mission {what}"))  # fmt: skip
            home = depot_xy(m, depot)
            if paced is not None and home is not None:
                n += 1
                e, nn = xy - home
                d = float(np.hypot(paced[0] - e, paced[1] - nn))
                if d > PLACE_TOL_M:
                    off.append((d, f"vehicle {sc.vehicle} sortie {sc.sortie} {what} "
                                   f"{paced[0]:g} m east, {paced[1]:g} m north of '{depot}' in "
                                   f"fleet.json, {d:.1f} m from where its mission {what}"))
    for name, (lat, lon) in fleet.depots.items():
        home = depot_xy(m, name)
        if home is None:
            off.append((np.inf, f"depot '{name}' in fleet.json is not one of the map's "
                                f"({', '.join(names)})"))  # fmt: skip
            continue
        x, y = latlon_to_enu(lat, lon, m)
        d = float(np.hypot(float(x) - home[0], float(y) - home[1]))
        if d > PLACE_TOL_M:
            off.append((d, f"depot '{name}' at lat {lat:.7f}, lon {lon:.7f} in fleet.json, "
                           f"{d:.1f} m from the map's"))  # fmt: skip
        local = fleet.depots_xy.get(name)
        if local is not None:
            d = float(np.hypot(local[0] - home[0], local[1] - home[1]))
            if d > PLACE_TOL_M:
                off.append((d, f"depot '{name}' at x {local[0]:g}, y {local[1]:g} m in "
                               f"fleet.json, {d:.1f} m from the map's"))  # fmt: skip
    if not off:
        return Verdict("PLACES", title, True, 0.0, "m",
                       f"the {n} places fleet.json gives are the missions' own" if n else
                       "fleet.json gives no places (written before each vehicle had its own "
                       "pad)")  # fmt: skip
    off.sort(key=lambda o: -o[0])
    more = f"; {len(off)} places differ" if len(off) > 1 else ""
    worst = off[0][0] if np.isfinite(off[0][0]) else 1e9
    return Verdict("PLACES", title, False, -(worst - PLACE_TOL_M), "m",
                   f"{off[0][1]}{more}: the crew sets the vehicles where fleet.json and upload "
                   "(pacing from fleet.json's depots) say, the vehicles fly the missions'")


def _pads_note(m: Any, check: FleetCheck) -> str | None:
    """When a sortie's ENDS fails because its mission takes off or lands on another spot than
    its vehicle's pad on this map: a line saying so (a directory planned before each vehicle
    had its own pad, or with another fleet.separation_m, safety.clearance or obstacles near a
    depot, is planned again)."""
    from planner_core.model.pads import pad_ranks

    worst = None
    names = list(m.sortie_sites[0])
    rank = pad_ranks((sc.vehicle, d) for sc in check.sorties
                     for d in (sc.depot_start, sc.depot_end))  # fmt: skip
    for sc in check.sorties:
        if not any(v.name == "ENDS" and not v.passed for v in sc.verdicts):
            continue
        if sc.depot_start not in names:
            continue
        k = rank[(sc.vehicle, sc.depot_start)]
        pad = m.pads_for(max(int(m.uavs), k + 1))[k, names.index(sc.depot_start)]
        d = float(np.hypot(*(sc.takeoff_xy - pad)))
        if worst is None or d > worst[0]:
            worst = (d, sc, pad)
    if worst is None:
        return None
    d, sc, pad = worst
    return (f"vehicle {sc.vehicle} sortie {sc.sortie} takes off {d:.1f} m from its pad at "
            f"'{sc.depot_start}' on this map ({pad_words(m, sc.depot_start, pad)}; each vehicle "
            f"has its own pad, fleet.separation_m + 5 m apart): a directory planned before "
            "pads, or on a map with another fleet.separation_m, safety.clearance or obstacles "
            "near a depot, is planned again")


def _moved_takeoffs(given: list[tuple[int, int, float | None]], clock: list[float]
                    ) -> list[tuple[int, int, float, float]]:
    """(vehicle, sortie, fleet.json's time, the clock's) of each take-off fleet.json gives
    more than `formats.fleet.CLOCK_TOL_S` from `clock` (the replay's take-offs, in the same
    order)."""
    from lamde_mission.formats.fleet import CLOCK_TOL_S

    return [(v, k, t, c) for (v, k, t), c in zip(given, clock, strict=True)
            if t is not None and abs(t - c) > CLOCK_TOL_S]


def _times_at_limits(given: list[tuple[int, int, float | None]], clock: list[float]) -> Any:
    """TIMES when the directory is judged at the vehicles' speed limits (`upload --fleet --map`
    below the planned speed): fleet.json's times are the planned speeds', so a slower vehicle's
    later take-offs move by design; the verdict holds and says by how much (the times
    themselves are judged at the planned speeds, `verify MAP DIR/` and upload's first check).
    A reviewer's two-sortie vehicle at PX4's default 12 m/s failed TIMES on every upload."""
    from sim.checks import Verdict

    moved = _moved_takeoffs(given, clock)
    detail = ("no take-off moves at these speeds" if not moved else
              f"at these speeds vehicle {moved[0][0]} sortie {moved[0][1]} takes off at "
              f"{moved[0][3]:.1f} s, not fleet.json's {moved[0][2]:g} s (planned speeds)"
              + (f"; {len(moved)} take-offs move" if len(moved) > 1 else ""))
    return Verdict("TIMES", "take-off times at the vehicles' speed limits", True, 0.0, "s",
                   detail)


def _times_verdict(given: list[tuple[int, int, float | None]], clock: list[float],
                   swap_given: float | None, swap_map: float) -> Any:
    """TIMES: the take-off times fleet.json gives (what `upload --fleet` prints for the crew)
    are the plan's clock as verified: the launches, the sorties' replays and the map's swap_s.
    A hand-edited time, or a map whose swap_s is not the one planned with, fails it."""
    from sim.checks import Verdict

    title = "fleet.json's take-off times are the verified ones"
    off = _moved_takeoffs(given, clock)
    swap = ("" if swap_given is None or swap_given == swap_map else
            f"; fleet.json was planned with swap_s {swap_given:g} s, the map says {swap_map:g} "
            "s, which moves every later take-off")
    if not off and not swap:
        n = sum(t is not None for _, _, t in given)
        return Verdict("TIMES", title, True, 0.0, "s",
                       f"the {n} take-off times fleet.json gives are the plan's clock" if n
                       else "fleet.json gives no take-off times (the launches only)")
    worst = max((abs(t - c) for _, _, t, c in off), default=0.0)
    first = "" if not off else (
        f"vehicle {off[0][0]} sortie {off[0][1]} at {off[0][2]:g} s in fleet.json, "
        f"{off[0][3]:.1f} s on the plan's clock (launch, sorties, swap_s)"
        + (f"; {len(off)} sorties differ" if len(off) > 1 else ""))
    return Verdict("TIMES", title, False, -worst, "s",
                   (first + swap).lstrip("; ") + ": upload prints fleet.json's times, the "
                   "checks hold at the plan's clock")


def _unknown_depot(fleet: Any, map_name: str, depots: Sequence[str], vehicle: int, s: Any,
                   which: str, depot: str) -> str:
    """The line for a sortie whose depot `map_name` lacks: fleet.json, the vehicle, sortie and
    file, the depot and the map's depots; when fleet.json names another map (the usual cause:
    `verify MAP DIR/` with the wrong MAP), that the directory was planned on it."""
    verb = "takes off at" if which == "depot_start" else "lands at"
    line = (f"{fleet.path / FLEET_FILE}: vehicle {vehicle} sortie {s.sortie} ({s.path.name}) "
            f"{verb} depot '{depot}', which map '{map_name}' does not have (its depots: "
            f"{', '.join(depots)})")
    if fleet.map_name is not None and fleet.map_name != map_name:
        line += f"; the directory was planned on map '{fleet.map_name}', not '{map_name}'"
    return line


def summary_dict(m: Any, check: FleetCheck, goal: str) -> dict[str, Any]:
    """fleet.json's content for a checked plan (module docstring): every figure the
    simulator's, on the stored missions.

    Args:
        m: the plan's map.
        check: the stored missions' replays (`_check`).
        goal: the objective the plan was made for.

    Returns:
        The JSON object.
    """
    vehicles = []
    for v, ss in check.vehicles().items():
        vehicles.append({
            "vehicle": v,
            "sorties": [{
                "sortie": s.sortie, "file": s.file, "depot_start": s.depot_start,
                "depot_end": s.depot_end,
                "takeoff_at": _position(m, s.takeoff_xy, s.depot_start),
                "landing_at": _position(m, s.landing_xy, s.depot_end),
                "takeoff_s": (at := check.takeoff(v, k + 1)),
                "landing_s": at + s.duration_s,
                "duration_s": s.duration_s,
                "energy_wh": s.verdicts.energy_wh, "reserve_left_wh": s.verdicts.reserve_left_wh,
                "above_reserve_wh": s.verdicts.above_reserve_wh,
                "sensors": list(s.sensors),
            } for k, s in enumerate(ss)],
            "launch_s": check.launch(v),
            "makespan_s": check.makespan(v),
        })  # fmt: skip
    tolerance = {} if check.timing_tolerance_s is None else {
        "timing_tolerance_s": check.timing_tolerance_s}
    used = {d for x in check.sorties for d in (x.depot_start, x.depot_end)}
    out: dict[str, Any] = {
        "map": m.name,
        "objective": goal,
        "depots": dict(sorted(depot_positions(m, used).items())),
        "vehicles": vehicles,
        "total_s": check.total_s,
        "swaps": check.swaps,
        "swap_s": check.swap_s,
        "f_total": check.f_total,
        **tolerance,
    }
    return out


def _stored_sorties(plan: Any, m: Any, autopilot: str) -> list[tuple[Any, ...]]:
    """Each sortie of `plan` as it is stored (`write_sortie_dir`): (vehicle, sortie, file name,
    start depot, end depot, its stored items, the stored plan, its sortie map and that map's
    planning map), vehicle by vehicle. Cost: one storage (`storable_plan`) per sortie."""
    from lamde_mission.items import plan_to_items
    from lamde_mission.storage import storable_plan, stored_items
    from planner_core.fleet import collected_by_sortie
    from planner_core.model.formulas import ModelParams
    from planner_core.model.pads import pad_ranks

    st = plan.settings
    shares = collected_by_sortie(plan, ModelParams.from_map(m.planning_map()))  # Mbit, margin in
    margin = 1.0 + float(m.spec.safety.data_margin)
    out = []
    k = 0
    # each vehicle's pads as verify finds them (the plan's own when it is on its pads:
    # `planner_core.fleet.search.on_pads` counts them the same way)
    rank = pad_ranks((v, st.depot_names[d]) for v, vs in enumerate(plan.vehicles, start=1)
                     for s in vs for d in (s.start, s.end))  # fmt: skip
    for v, vs in enumerate(plan.vehicles, start=1):
        for n, s in enumerate(vs, start=1):
            a, b = st.depot_names[s.start], st.depot_names[s.end]
            sm = sortie_map(m, a, b, shares[k] / margin, name=f"{m.name} v{v} s{n}",
                            pads=(rank[(v, a)], rank[(v, b)]))
            k += 1
            spm = sm.planning_map()
            p = SimpleNamespace(hover_points=s.points, hover_times=s.times)
            stored = storable_plan(p, sm, autopilot, planning_map=spm, finish="land")
            items = stored_items(plan_to_items(stored, sm, finish="land"), stored.dialect)
            out.append((v, n, sortie_file(v, n), a, b, items, stored, sm, spm))
    return out


def launch_check(plan: Any, m: Any, autopilot: str = "generic") -> FleetCheck:
    """The verdicts `write_sortie_dir` would give `plan` on map `m`, nothing written: each
    sortie stored and replayed, the vehicles' launches staggered (`lamde_mission.launches.
    stagger`), so its `fleet_makespan` is the makespan the operator flies, launches
    included. Cost: one storage and one replay per sortie, and the
    stagger's (`lamde_mission.launches`).

    Args:
        plan: a `planner_core.fleet.FleetPlan` made on `m.planning_map()`.
        m: the map.
        autopilot: the stored missions' dialect ("generic", "px4" or "ardupilot").

    Returns:
        The `FleetCheck` (no FILES verdict: there is no directory).
    """
    rows = [r[:6] for r in _stored_sorties(plan, m, autopilot)]
    return _check(m, rows, len(plan.vehicles), None)


def write_sortie_dir(
    plan: Any,
    m: Any,
    out_dir: str | Path,
    *,
    autopilot: str = "generic",
    goal: str | None = None,
    allow_infeasible: bool = False,
) -> tuple[FleetCheck, bool]:
    """Store, write and verify the fleet plan `plan` (`planner_core.fleet.FleetPlan`, made on
    `m.planning_map()`) as the sortie directory `out_dir` (module docstring).

    Args:
        plan: the fleet plan.
        m: the map (with its origin).
        out_dir: the directory to create, or to replace when it is empty or an earlier sortie
            directory (`sortie_dir_refusal`).
        autopilot: "generic", "px4" or "ardupilot" (`lamde_mission.storage`).
        goal: the objective named in fleet.json: None for the plan's own
            (`plan.settings.goal`, what it was made for); given, it must be that one.
        allow_infeasible: write it even when a verdict fails.

    The directory is filled as `.NAME.lamde-pending-PID` beside `out_dir` and renamed onto it
    last; a directory it replaces is moved to `.NAME.lamde-old-PID` and removed after. A write
    killed (SIGKILL, power loss) leaves those folders behind: each write removes, before it
    starts, the pending folders beside `out_dir` whose process PID no longer runs, and once its
    directory is in place the old ones of such processes (`planner_core.atomic.
    clean_stale_dirs`); a folder of a process still running (another write in progress) is
    never touched, so they do not accumulate.

    Returns:
        (the `FleetCheck` of the stored missions, whether the directory was written).

    Raises:
        FileExistsError: `out_dir` is a file, the working folder (or above it) or a folder
            holding anything but a sortie directory's files (`sortie_dir_refusal`); checked
            before anything is written.
        OSError: the directory cannot be written (nothing is left half-written).
        ValueError: `goal` is not the plan's, or the plan has more vehicles or sorties than
            a sortie directory may list (`MAX_FLEET_VEHICLES`, `MAX_FLEET_SORTIES`; before
            anything is written).
    """
    from lamde_mission.formats import write_mission

    st = plan.settings
    if goal is not None and goal != st.goal:
        raise ValueError(f"goal: '{goal}', but the plan was made for '{st.goal}' (leave goal "
                         "out to name the plan's own)")  # fmt: skip
    goal = st.goal
    n_sorties = sum(len(vs) for vs in plan.vehicles)
    if len(plan.vehicles) > MAX_FLEET_VEHICLES or n_sorties > MAX_FLEET_SORTIES:
        raise ValueError(f"the plan has {counted(n_sorties, 'sortie')} on "
                         f"{counted(len(plan.vehicles), 'vehicle')}, "
                         f"more than a sortie directory holds ({MAX_FLEET_SORTIES:,} sorties, "
                         f"{MAX_FLEET_VEHICLES} vehicles)")  # fmt: skip
    refusal = sortie_dir_refusal(out_dir)
    if refusal is not None:
        raise FileExistsError(f"{out_dir}: {refusal}")
    target = Path(out_dir).resolve()
    clean_stale_dirs(target, ("pending",))  # what killed writes to it left beside it
    pending = dir_beside(target, "pending")
    if pending.exists():
        shutil.rmtree(pending)
    pending.mkdir(parents=False)
    try:
        rows = []
        for v, n, f, a, b, items, stored, sm, spm in _stored_sorties(plan, m, autopilot):
            write_mission(pending / f, stored, sm, "plan", finish="land", autopilot=autopilot,
                          planning_map=spm)
            rows.append((v, n, f, a, b, items))
        check = _check(m, rows, len(plan.vehicles), pending)
        if not check.passed and not allow_infeasible:
            return check, False
        (pending / FLEET_FILE).write_text(
            json.dumps(summary_dict(m, check, goal), indent=2) + "\n", encoding="utf-8"
        )
        old = None
        if target.exists():
            old = dir_beside(target, "old")
            os.replace(target, old)
        try:
            os.replace(pending, target)
        except BaseException:
            if old is not None:  # the folder it was to replace goes back to its path
                os.replace(old, target)
            raise
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
        # a write killed between its two renames left the directory it replaced: superseded now
        clean_stale_dirs(target, ("old",))
        return check, True
    finally:
        if pending.exists():
            shutil.rmtree(pending, ignore_errors=True)

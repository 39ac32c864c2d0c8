"""A sortie directory, as `lamde-mission plan MAP -o DIR/` writes it for a battery or a fleet:
`DIR/fleet.json` and one QGroundControl `.plan` per vehicle and sortie.

`read_fleet_dir` reads and checks what the readers need (`upload --fleet`, `show MAP DIR/`):

    {"map": name, "objective": "total" | "makespan",
     "vehicles": [{"vehicle": 1, "makespan_s": s,
                   "sorties": [{"sortie": 1, "file": "mission-v1-s1.plan",
                                "depot_start": "home", "depot_end": "home",
                                "takeoff_at": {"lat": deg, "lon": deg, ...},
                                "landing_at": {"lat": deg, "lon": deg, ...},
                                "takeoff_s": s, "duration_s": s, "energy_wh": Wh,
                                "reserve_left_wh": Wh, "above_reserve_wh": Wh,
                                "sensors": ["s01", ...]}, ...]}, ...],
     "total_s": s, "swaps": n, "depots": {"home": {"lat": deg, "lon": deg, ...}, ...}}

Vehicles are numbered 1..V and sorties 1..S_k in order (1-based, as in the file names
`mission-v{vehicle}-s{sortie}.plan`); every sortie's file is a plain name inside DIR, exists and
is no other sortie's (a file listed twice, by name or as the same file, is refused); a sortie's
depots are among fleet.json's `depots` where it gives them. Figures (durations, energies) are
kept when present and finite, else None; `"energy_wh": null` says the plan's map had no battery
(`FleetSortie.no_battery`). A field the writer does not write (`FLEET_FIELDS` and the others,
as `lamde_mission.sorties.summary_dict` writes them) is refused naming it, with the field
meant where one is near ("did you mean"), as the map reader refuses one: a misspelt field would
otherwise be read as absent. At most `MAX_FLEET_VEHICLES` vehicles (100, `fleet.uavs`' most)
and `MAX_FLEET_SORTIES` sorties in all (1,000; `planner_core.defaults`), checked before any
sortie is read: what follows (`verify DIR/` replays every sortie) grows with them. Reading costs
O(vehicles + sorties).

`FleetDir.disagreements` holds fleet.json to itself and to its mission files without a map:
each take-off time to its vehicle's launch, the sorties before it and `swap_s`, landings,
makespans, `total_s` and `swaps` to the durations, every sortie's battery to the others', and
the take-off and landing places (`takeoff_at`, `landing_at`, paced from `depots`) to where the
mission files take off and land. `upload DIR/ --fleet` refuses a directory that fails it (what
it prints for the crew is fleet.json's), `show` notes it; `verify MAP DIR/` holds every figure
to the replays themselves (`lamde_mission.sorties`: TIMES, PLACES, FIGURES).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from lamde_mission.sorties import FLEET_FILE, sortie_file  # the writer's names, one place
from planner_core.defaults import MAX_FLEET_SORTIES, MAX_FLEET_VEHICLES
from planner_core.textio import InputError, did_you_mean, printable, quoted, read_json

__all__ = ["FLEET_FILE", "MAX_FLEET_SORTIES", "MAX_FLEET_VEHICLES", "FleetDirError",
           "FleetSortie", "FleetVehicle", "FleetDir", "read_fleet_dir",
           "sortie_file_name", "FLEET_FIELDS", "VEHICLE_FIELDS", "SORTIE_FIELDS",
           "PLACE_FIELDS", "DEPOT_FIELDS", "CLOCK_TOL_S", "ENERGY_TOL_WH", "PLACE_TOL_M",
           "PACE_TOL"]  # fmt: skip

#: the fields of fleet.json, of each vehicle, each sortie, each `takeoff_at` / `landing_at`
#: and each depot of `depots`: what `lamde_mission.sorties.summary_dict` writes (a test holds
#: the two together); any other is refused
FLEET_FIELDS = ("map", "objective", "depots", "vehicles", "total_s", "swaps", "swap_s",
                "f_total", "timing_tolerance_s")  # fmt: skip
VEHICLE_FIELDS = ("vehicle", "sorties", "launch_s", "makespan_s")
SORTIE_FIELDS = ("sortie", "file", "depot_start", "depot_end", "takeoff_at", "landing_at",
                 "takeoff_s", "landing_s", "duration_s", "energy_wh", "reserve_left_wh",
                 "above_reserve_wh", "sensors")  # fmt: skip
PLACE_FIELDS = ("x", "y", "lat", "lon", "east_m", "north_m")
DEPOT_FIELDS = ("x", "y", "lat", "lon")

#: s: a time fleet.json gives this far from the one its own figures (or the replay) give is
#: another time (the JSON keeps full floats; a crew launches to the half minute)
CLOCK_TOL_S = 0.5
#: Wh: an energy this far from the one the other figures (or the replay) give is another
#: energy (the JSON keeps full floats)
ENERGY_TOL_WH = 0.01
#: m: a place fleet.json gives this far from the mission's is another place (a position on
#: the 1e-7 degree grid moves by about 1 cm, a pad's offset is kept to the centimetre)
PLACE_TOL_M = 0.1
#: paced from a depot without the map, a pad's offset is judged to this share of its length
#: more: fleet.json's `east_m`, `north_m` are in the map's frame, the pacing in the depot's own
#: (the two turn apart by up to ~0.5 % 30 km from the map's origin); pads are 35 m apart
PACE_TOL = 0.01


class FleetDirError(ValueError):
    """A sortie directory that cannot be read: one line naming the file and the field."""


#: s, the latest take-off time fleet.json may give (a sortie's `takeoff_s`): MAX_FLEET_SORTIES
#: sorties of a day each
MAX_CLOCK_S = 1e8


def sortie_file_name(vehicle: int, sortie: int) -> str:
    """The file of vehicle `vehicle`'s sortie `sortie` (both 1-based), as the writer
    (`lamde_mission.sorties.sortie_file`) names it: mission-v1-s2.plan.

    Args:
        vehicle: the vehicle's number, 1-based.
        sortie: the sortie's number on that vehicle, 1-based.

    Returns:
        The file name inside the directory.
    """
    return sortie_file(vehicle, sortie)


@dataclass(frozen=True)
class FleetSortie:
    """One sortie: its number, file (a path inside the directory) and summary figures."""

    sortie: int
    path: Path
    depot_start: str | None = None
    depot_end: str | None = None
    duration_s: float | None = None
    energy_wh: float | None = None
    reserve_left_wh: float | None = None
    #: Wh, usable - energy (negative: into the reserve; None where fleet.json gives none)
    above_reserve_wh: float | None = None
    #: fleet.json gives "energy_wh": null, as `plan` writes it for a map without a battery:
    #: no ENERGY to judge. False where it gives an energy, and where it gives no energy_wh at
    #: all (not known: a reader that needs to know takes it for a battery)
    no_battery: bool = False
    sensors: tuple[str, ...] = ()
    #: s after the first vehicle's take-off (None when fleet.json gives none: written before
    #: take-off times were)
    takeoff_s: float | None = None
    #: (lat, lon) degrees of the vehicle's pad the sortie takes off from (`takeoff_at`; None
    #: when fleet.json gives none: written before each vehicle had its own pad)
    takeoff_at: tuple[float, float] | None = None
    #: (lat, lon) degrees of the pad it lands at (`landing_at`; None as `takeoff_at`)
    landing_at: tuple[float, float] | None = None
    #: (east_m, north_m) of the take-off and landing pads from their depots, as fleet.json
    #: gives them for the crew (None where it gives none)
    takeoff_offset: tuple[float, float] | None = None
    landing_offset: tuple[float, float] | None = None
    #: s, when it lands on the plan's clock (`landing_s`; None when fleet.json gives none)
    landing_s: float | None = None
    #: (x, y) local m of the take-off and landing pads, as fleet.json gives them (None where
    #: it gives none)
    takeoff_xy: tuple[float, float] | None = None
    landing_xy: tuple[float, float] | None = None


@dataclass(frozen=True)
class FleetVehicle:
    """One vehicle: its number and sorties in flying order (possibly none)."""

    vehicle: int
    sorties: tuple[FleetSortie, ...]
    makespan_s: float | None = None
    #: s after the first vehicle's take-off (0 when fleet.json gives none)
    launch_s: float = 0.0
    #: whether fleet.json gives `launch_s` (a directory written before launches has none)
    launch_given: bool = False


@dataclass(frozen=True)
class FleetDir:
    """A sortie directory read by `read_fleet_dir`."""

    path: Path
    vehicles: tuple[FleetVehicle, ...]
    map_name: str | None = None
    objective: str | None = None
    total_s: float | None = None
    #: s, the battery swap the plan was made with (None when fleet.json gives none: written
    #: before it was recorded)
    swap_s: float | None = None
    swaps: int | None = None
    #: {depot name: (lat, lon) degrees} of the depots the sorties use (empty when fleet.json
    #: gives none: written before each vehicle had its own pad)
    depots: dict[str, tuple[float, float]] = field(default_factory=dict)
    raw: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)
    #: the objective "total" on the replays (`f_total`; None when fleet.json gives none)
    f_total: float | None = None
    #: s each sortie may take off early or late (`timing_tolerance_s`; None when fleet.json
    #: gives none: one vehicle, or written before it was recorded)
    timing_tolerance_s: float | None = None
    #: {depot name: (x, y) local m} as fleet.json gives them (those without x and y left out)
    depots_xy: dict[str, tuple[float, float]] = field(default_factory=dict)

    def map_note(self, map_name: str, verb: str) -> str | None:
        """The note when fleet.json names another map than the one given, else None.

        Args:
            map_name: the name of the map the directory is read with.
            verb: what is done on it ("drawn", "verified").

        Returns:
            "DIR: planned on map 'A', {verb} on 'B'" (printable), or None when the names agree
            or fleet.json names no map.
        """
        from planner_core.textio import printable

        if self.map_name is None or self.map_name == map_name:
            return None
        return printable(f"{self.path}: planned on map '{self.map_name}', {verb} on "
                         f"'{map_name}'")  # fmt: skip

    def first_sorties(self) -> list[FleetSortie | None]:
        """Each vehicle's first sortie, in vehicle order.

        Returns:
            One `FleetSortie` per vehicle, None for a vehicle with none.
        """
        return self.sorties_numbered(1)

    def sorties_numbered(self, sortie: int) -> list[FleetSortie | None]:
        """Each vehicle's sortie `sortie`, in vehicle order.

        Args:
            sortie: the sortie's number, 1-based.

        Returns:
            One `FleetSortie` per vehicle, None for a vehicle with fewer (every entry None
            for `sortie` < 1).
        """
        return [v.sorties[sortie - 1] if len(v.sorties) >= sortie >= 1 else None
                for v in self.vehicles]  # fmt: skip

    def disagreements(self) -> list[str]:
        """Where fleet.json disagrees with itself or with its mission files, judged without a
        map (module docstring): what `upload DIR/ --fleet` would print for the crew from it
        is then not the plan. A figure fleet.json does not give is not judged (a directory
        written before it was recorded).

        Judged, each to `CLOCK_TOL_S`, `ENERGY_TOL_WH` or `PLACE_TOL_M`: each `takeoff_s`
        against its vehicle's `launch_s` (sortie 1) or the sortie before's take-off +
        `duration_s` + `swap_s`; `landing_s` against its take-off + `duration_s`; a vehicle's
        `makespan_s` against its last landing; `total_s` against the durations + `swap_s` per
        swap and `swaps` against the sorties after each vehicle's first; `energy_wh` null
        beside a `reserve_left_wh` or `above_reserve_wh`, and each sortie's battery
        (`energy_wh` + `reserve_left_wh`) and usable energy (+ `above_reserve_wh`) against
        those most sorties give; `takeoff_at` / `landing_at` (`lat`, `lon`) against where the
        mission file's NAV_TAKEOFF / last NAV_LAND stands, its `east_m`, `north_m` against
        that place paced from the depot's `lat`, `lon` in `depots` (to `PLACE_TOL_M` +
        `PACE_TOL` of the offset) and against its `x`, `y` less the depot's.

        Returns:
            One line per disagreement, each naming fleet.json, the field (`vehicles[1].
            sorties[0].takeoff_s`), its value and what it should agree with, in fleet.json's
            order (the batteries last); empty when all agree. Cost: O(sorties + their mission
            files' items).
        """
        summary = self.path / FLEET_FILE
        out: list[str] = []
        swap = self.swap_s
        energies: list[tuple[str, float, float | None, float | None]] = []
        after_first = 0
        durations = 0.0
        for k, v in enumerate(self.vehicles):
            at = v.launch_s if v.launch_given else None  # this sortie's take-off by the clock
            why = f"vehicle {v.vehicle}'s launch_s {v.launch_s:g} s"
            landed = None
            for j, s in enumerate(v.sorties):
                w = f"{summary}: vehicles[{k}].sorties[{j}]"
                if at is not None and s.takeoff_s is not None and abs(s.takeoff_s - at) > \
                        CLOCK_TOL_S:
                    out.append(f"{w}.takeoff_s: {s.takeoff_s:g} s, but fleet.json's own clock "
                               f"gives {at:.1f} s ({why})")  # fmt: skip
                start = at if at is not None else s.takeoff_s
                landed = None if start is None or s.duration_s is None else start + s.duration_s
                if landed is not None and s.landing_s is not None and \
                        abs(s.landing_s - landed) > CLOCK_TOL_S:
                    out.append(f"{w}.landing_s: {s.landing_s:g} s, but its take-off "
                               f"{start:.1f} s + duration_s {s.duration_s:g} s is "
                               f"{landed:.1f} s")  # fmt: skip
                at = None if landed is None or swap is None else landed + swap
                if at is not None:
                    why = (f"sortie {s.sortie}'s take-off {start:.1f} s + duration_s "
                           f"{s.duration_s:g} s + swap_s {swap:g} s")
                out += _place_lines(w, s, self)
                if s.no_battery and (s.reserve_left_wh, s.above_reserve_wh) != (None, None):
                    other = ("reserve_left_wh" if s.reserve_left_wh is not None
                             else "above_reserve_wh")
                    out.append(f"{w}.energy_wh: null (planned without a battery), but "
                               f"{other} is {getattr(s, other):g} Wh")  # fmt: skip
                elif s.energy_wh is not None:
                    energies.append((w, s.energy_wh, s.reserve_left_wh, s.above_reserve_wh))
                durations += s.duration_s if s.duration_s is not None else math.nan
            after_first += max(len(v.sorties) - 1, 0)
            if landed is not None and v.makespan_s is not None and \
                    abs(v.makespan_s - landed) > CLOCK_TOL_S:
                out.append(f"{summary}: vehicles[{k}].makespan_s: {v.makespan_s:g} s, but its "
                           f"last sortie lands at {landed:.1f} s (launch, sorties and swaps)")
        if self.swaps is not None and self.swaps != after_first:
            out.append(f"{summary}: swaps: {self.swaps}, but the vehicles fly {after_first} "
                       "sorties after their first")  # fmt: skip
        total = durations + (swap or 0.0) * after_first if swap is not None or not after_first \
            else math.nan
        if self.total_s is not None and math.isfinite(total) and \
                abs(self.total_s - total) > CLOCK_TOL_S:
            out.append(f"{summary}: total_s: {self.total_s:g} s, but the sorties' duration_s and "
                       f"swap_s per swap sum to {total:.1f} s")  # fmt: skip
        return out + _energy_lines(energies)

    def disagreement(self) -> str | None:
        """`disagreements` in one line: the first, and how many more.

        Returns:
            The line (printable), or None when fleet.json agrees with itself and its missions.
        """
        off = self.disagreements()
        if not off:
            return None
        more = f" (and {len(off) - 1} more disagreement{'s' if len(off) > 2 else ''})" \
            if len(off) > 1 else ""
        return printable(off[0] + more)


def _most_given(values: Sequence[float], tol: float) -> float:
    """The value most of `values` give to within `tol` (the middle of the widest run of
    sorted values spanning at most 2 tol; the lowest such run on a tie); nan when empty.
    Cost: O(n log n)."""
    vals = sorted(values)
    best, ref, lo = 0, math.nan, 0
    for hi, x in enumerate(vals):
        while x - vals[lo] > 2.0 * tol:
            lo += 1
        if hi - lo + 1 > best:
            best, ref = hi - lo + 1, 0.5 * (vals[lo] + x)
    return ref


def _energy_lines(energies: list[tuple[str, float, float | None, float | None]]) -> list[str]:
    """`FleetDir.disagreements`' lines for the sorties' energies: (where, energy_wh,
    reserve_left_wh, above_reserve_wh) of each sortie with an energy. Every sortie flies one
    battery, so energy + reserve left (the battery) and energy + what is left above the reserve
    (the usable energy) are the same for all: a sortie off both names its energy_wh, off one
    the other figure. Cost: O(n log n)."""
    battery = _most_given([e + r for _, e, r, _ in energies if r is not None], ENERGY_TOL_WH)
    usable = _most_given([e + a for _, e, _, a in energies if a is not None], ENERGY_TOL_WH)
    out = []
    for w, e, r, a in energies:
        b_off = r is not None and abs(e + r - battery) > ENERGY_TOL_WH
        u_off = a is not None and abs(e + a - usable) > ENERGY_TOL_WH
        if b_off and u_off and r is not None and a is not None:
            out.append(f"{w}.energy_wh: {e:g} Wh, but with reserve_left_wh {r:g} Wh the battery "
                       f"is {e + r:.3f} Wh and with above_reserve_wh {a:g} Wh the usable energy "
                       f"{e + a:.3f} Wh; the other sorties give {battery:.3f} and {usable:.3f} "
                       "Wh")  # fmt: skip
        elif b_off and r is not None:
            out.append(f"{w}.reserve_left_wh: {r:g} Wh, but with energy_wh {e:g} Wh the battery "
                       f"is {e + r:.3f} Wh; the other sorties give {battery:.3f} Wh")
        elif u_off and a is not None:
            out.append(f"{w}.above_reserve_wh: {a:g} Wh, but with energy_wh {e:g} Wh the usable "
                       f"energy is {e + a:.3f} Wh; the other sorties give {usable:.3f} Wh")
    return out


def _place_lines(w: str, s: FleetSortie, fleet: FleetDir) -> list[str]:
    """`FleetDir.disagreements`' lines for one sortie's take-off and landing places: fleet.json's
    `takeoff_at` / `landing_at` against where its mission file takes off (first NAV_TAKEOFF)
    and lands (last NAV_LAND, `lamde_mission.sorties.mission_stands`: an unreadable file gives
    none), paced from its depot, and against its own `x`, `y` less the depot's."""
    from lamde_mission.geo import latlon_to_enu
    from lamde_mission.sorties import NAV_LAND, NAV_TAKEOFF, mission_stands
    from planner_core.model.pads import offset_words

    stands = mission_stands(s.path)
    up = [(a, b) for c, a, b in stands if c == NAV_TAKEOFF][:1]
    down = [(a, b) for c, a, b in stands if c == NAV_LAND][-1:]
    out = []
    for key, what, given, paced, xy, depot, there in (
            ("takeoff_at", "takes off", s.takeoff_at, s.takeoff_offset, s.takeoff_xy,
             s.depot_start, up),
            ("landing_at", "lands", s.landing_at, s.landing_offset, s.landing_xy, s.depot_end,
             down)):  # fmt: skip
        if there and given is not None:
            e, n = latlon_to_enu(there[0][0], there[0][1], (given[0], given[1], 0.0))
            d = math.hypot(float(e), float(n))
            if d > PLACE_TOL_M:
                out.append(f"{w}.{key}: lat {given[0]:.7f}, lon {given[1]:.7f}, {d:.1f} m from "
                           f"where its file '{printable(s.path.name)}' {what} (lat "
                           f"{there[0][0]:.7f}, lon {there[0][1]:.7f})")  # fmt: skip
        home = fleet.depots.get(depot or "")
        if there and paced is not None and home is not None:
            e, n = latlon_to_enu(there[0][0], there[0][1], (home[0], home[1], 0.0))
            d = math.hypot(float(e) - paced[0], float(n) - paced[1])
            if d > PLACE_TOL_M + PACE_TOL * math.hypot(*paced):
                words = offset_words(float(e), float(n))
                place = (f"at '{printable(depot)}' itself" if words == "the depot itself"
                         else f"{words} of it")  # fmt: skip
                out.append(f"{w}.{key}: {paced[0]:g} m east, {paced[1]:g} m north of "
                           f"'{printable(depot)}', but its file '{printable(s.path.name)}' "
                           f"{what} {place}, {d:.1f} m from there")  # fmt: skip
        base = fleet.depots_xy.get(depot or "")
        if xy is not None and paced is not None and base is not None:
            d = math.hypot(xy[0] - base[0] - paced[0], xy[1] - base[1] - paced[1])
            if d > PLACE_TOL_M:
                out.append(f"{w}.{key}: x {xy[0]:g}, y {xy[1]:g} m is {xy[0] - base[0]:.2f} m "
                           f"east, {xy[1] - base[1]:.2f} m north of '{printable(depot)}' (x "
                           f"{base[0]:g}, y {base[1]:g} m in depots), not east_m {paced[0]:g}, "
                           f"north_m {paced[1]:g}")  # fmt: skip
    return out


def _number(v: Any, where: str) -> float | None:
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise FleetDirError(f"{where}: expected a finite number, got {quoted(v)}")
    return float(v)


def _index(v: Any, where: str, expected: int) -> int:
    if isinstance(v, bool) or not isinstance(v, int):
        raise FleetDirError(f"{where}: expected the whole number {expected}, got {quoted(v)}")
    if v != expected:
        raise FleetDirError(f"{where}: expected {expected} (numbered 1, 2, ... in order), got {v}")
    return v


def _known(v: dict[str, Any], fields: Sequence[str], where: str) -> None:
    """Refuse a field of `v` that fleet.json does not hold (`fields`), as the map reader
    refuses one: "{where}{field}: unknown field (did you mean 'x'?)" where one is near."""
    for key in v:
        if key not in fields:
            raise FleetDirError(f"{where}{printable(key)}: unknown field"
                                f"{did_you_mean(key, fields)}")


def _latlon(v: Any, where: str, fields: Sequence[str] = PLACE_FIELDS) -> tuple[float, float] | None:
    """A position's {"lat", "lon"} (WGS84 degrees), None when absent; its fields among
    `fields`."""
    if v is None:
        return None
    if not isinstance(v, dict):
        raise FleetDirError(f"{where}: expected an object with lat and lon, got {quoted(v)}")
    _known(v, fields, f"{where}.")
    lat, lon = _number(v.get("lat"), f"{where}.lat"), _number(v.get("lon"), f"{where}.lon")
    if lat is None or lon is None or not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        raise FleetDirError(f"{where}: expected lat in [-90, 90] and lon in [-180, 180] "
                            "degrees")  # fmt: skip
    return lat, lon


def _offset(v: Any, where: str, keys: tuple[str, str] = ("east_m", "north_m")
            ) -> tuple[float, float] | None:
    """A place's {"east_m", "north_m"} from its depot (or its other pair of metres `keys`,
    "x" and "y"), None when absent."""
    if not isinstance(v, dict) or (keys[0] not in v and keys[1] not in v):
        return None
    a, b = _number(v.get(keys[0]), f"{where}.{keys[0]}"), _number(v.get(keys[1]),
                                                                   f"{where}.{keys[1]}")
    if a is None or b is None:
        raise FleetDirError(f"{where}: expected both {keys[0]} and {keys[1]} (metres)")
    return a, b


def _name(v: Any, where: str) -> str | None:
    if v is None:
        return None
    if not isinstance(v, str):
        raise FleetDirError(f"{where}: expected a name (string), got {quoted(v)}")
    return v


def read_fleet_dir(path: str | Path) -> FleetDir:
    """Read and check a sortie directory (`DIR/fleet.json` and the `.plan` files it names).

    Args:
        path: the directory (or its fleet.json).

    Returns:
        The vehicles and their sorties, files resolved inside the directory.

    Raises:
        FleetDirError: one line naming the file and field: no such directory, no fleet.json,
            bad JSON, a field fleet.json does not hold (`FLEET_FIELDS` ...), vehicles or
            sorties out of order or more than `MAX_FLEET_VEHICLES` / `MAX_FLEET_SORTIES`, a
            file outside the directory, missing or listed by two sorties, a sortie's depot
            that fleet.json's `depots` do not give.
    """
    path = Path(path)
    if path.name == FLEET_FILE and path.is_file():
        path = path.parent
    if not path.is_dir():
        what = "no such directory" if not path.exists() else "not a directory"
        raise FleetDirError(f"{path}: {what} (expected a sortie directory written by "
                            "`lamde-mission plan MAP -o DIR/`)")  # fmt: skip
    summary = path / FLEET_FILE
    if not summary.is_file():
        raise FleetDirError(f"{summary}: no such file (a sortie directory holds {FLEET_FILE} "
                            "and mission-v{k}-s{j}.plan, as `lamde-mission plan MAP -o DIR/` "
                            "writes for a map with a battery or a fleet)")  # fmt: skip
    try:
        doc = read_json(summary)
    except InputError as exc:
        raise FleetDirError(f"{summary}: {exc}") from None
    if not isinstance(doc, dict):
        raise FleetDirError(f"{summary}: expected a JSON object")
    _known(doc, FLEET_FIELDS, f"{summary}: ")
    vs = doc.get("vehicles")
    if not isinstance(vs, list) or not vs:
        raise FleetDirError(f"{summary}: vehicles: expected a non-empty list")
    if len(vs) > MAX_FLEET_VEHICLES:
        raise FleetDirError(f"{summary}: vehicles: {len(vs):,} vehicles, more than "
                            f"{MAX_FLEET_VEHICLES}, the most a plan flies (fleet.uavs)")
    total = sum(len(v["sorties"]) for v in vs
                if isinstance(v, dict) and isinstance(v.get("sorties"), list))  # fmt: skip
    if total > MAX_FLEET_SORTIES:
        raise FleetDirError(f"{summary}: vehicles[].sorties: {total:,} sorties in all, more "
                            f"than {MAX_FLEET_SORTIES:,}, the most a sortie directory holds")
    vehicles = []
    files: dict[Any, tuple[int, int, str]] = {}  # a file (device, inode) -> who lists it
    depots_named: list[tuple[str, str]] = []  # (where, depot) of each sortie's depot
    for k, v in enumerate(vs):
        wv = f"{summary}: vehicles[{k}]"
        if not isinstance(v, dict):
            raise FleetDirError(f"{wv}: expected an object")
        _known(v, VEHICLE_FIELDS, f"{wv}.")
        number = _index(v.get("vehicle"), f"{wv}.vehicle", k + 1)
        ss = v.get("sorties", [])
        if not isinstance(ss, list):
            raise FleetDirError(f"{wv}.sorties: expected a list")
        sorties = []
        for j, s in enumerate(ss):
            ws = f"{wv}.sorties[{j}]"
            if not isinstance(s, dict):
                raise FleetDirError(f"{ws}: expected an object")
            _known(s, SORTIE_FIELDS, f"{ws}.")
            sortie = _index(s.get("sortie"), f"{ws}.sortie", j + 1)
            name = s.get("file", sortie_file_name(number, sortie))
            if (
                not isinstance(name, str)
                or not name
                or Path(name).name != name
                or name in (".", "..")
            ):
                raise FleetDirError(f"{ws}.file: expected a file name inside {path}, got "
                                    f"{quoted(name)}")  # fmt: skip
            fp = path / name
            if not fp.is_file():
                raise FleetDirError(f"{fp}: no such file (vehicle {number}, sortie {sortie} "
                                    f"in {summary})")  # fmt: skip
            st = fp.stat()  # one file under two names (a link, a case-blind disk) is one file
            seen = files.setdefault((st.st_dev, st.st_ino), (number, sortie, name))
            if seen != (number, sortie, name):
                also = "" if seen[2] == name else f" (as '{printable(seen[2])}', the same file)"
                raise FleetDirError(f"{ws}.file: {quoted(name)} is vehicle {seen[0]} sortie "
                                    f"{seen[1]}'s mission too{also}: each sortie flies a file "
                                    "of its own")  # fmt: skip
            sensors = s.get("sensors", [])
            if not isinstance(sensors, list) or not all(isinstance(x, str) for x in sensors):
                raise FleetDirError(f"{ws}.sensors: expected a list of sensor ids")
            takeoff = _number(s.get("takeoff_s"), f"{ws}.takeoff_s")
            if takeoff is not None and not 0.0 <= takeoff <= MAX_CLOCK_S:
                raise FleetDirError(f"{ws}.takeoff_s: expected seconds in [0, {MAX_CLOCK_S:g}], "
                                    f"got {takeoff:g}")  # fmt: skip
            ends = {key: _name(s.get(key), f"{ws}.{key}") for key in ("depot_start", "depot_end")}
            depots_named += [(f"{ws}.{key}", d) for key, d in ends.items() if d is not None]
            sorties.append(FleetSortie(
                sortie=sortie, path=fp, **ends,
                duration_s=_number(s.get("duration_s"), f"{ws}.duration_s"),
                energy_wh=_number(s.get("energy_wh"), f"{ws}.energy_wh"),
                reserve_left_wh=_number(s.get("reserve_left_wh"), f"{ws}.reserve_left_wh"),
                above_reserve_wh=_number(s.get("above_reserve_wh"), f"{ws}.above_reserve_wh"),
                no_battery="energy_wh" in s and s["energy_wh"] is None,
                sensors=tuple(sensors), takeoff_s=takeoff,
                takeoff_at=_latlon(s.get("takeoff_at"), f"{ws}.takeoff_at"),
                landing_at=_latlon(s.get("landing_at"), f"{ws}.landing_at"),
                takeoff_offset=_offset(s.get("takeoff_at"), f"{ws}.takeoff_at"),
                landing_offset=_offset(s.get("landing_at"), f"{ws}.landing_at"),
                landing_s=_number(s.get("landing_s"), f"{ws}.landing_s"),
                takeoff_xy=_offset(s.get("takeoff_at"), f"{ws}.takeoff_at", ("x", "y")),
                landing_xy=_offset(s.get("landing_at"), f"{ws}.landing_at", ("x", "y")),
            ))  # fmt: skip
        launch = _number(v.get("launch_s"), f"{wv}.launch_s")
        if launch is not None and not 0.0 <= launch <= 1e6:
            raise FleetDirError(f"{wv}.launch_s: expected seconds in [0, 1e6], got {launch:g}")
        vehicles.append(
            FleetVehicle(number, tuple(sorties), _number(v.get("makespan_s"), f"{wv}.makespan_s"),
                         0.0 if launch is None else launch, launch is not None)
        )
    swaps = doc.get("swaps")
    if swaps is not None and (isinstance(swaps, bool) or not isinstance(swaps, int)):
        raise FleetDirError(f"{summary}: swaps: expected a whole number, got {quoted(swaps)}")
    depots_doc = doc.get("depots", {})
    if not isinstance(depots_doc, dict) or len(depots_doc) > MAX_FLEET_SORTIES:
        raise FleetDirError(f"{summary}: depots: expected an object of depot names, got "
                            f"{quoted(depots_doc)}")  # fmt: skip
    depots, depots_xy = {}, {}
    for name, where in depots_doc.items():
        wd = f"{summary}: depots.{printable(name)}"
        got = _latlon(where, wd, DEPOT_FIELDS)
        if got is not None:
            depots[str(name)] = got
            xy = _offset(where, wd, ("x", "y"))
            if xy is not None:
                depots_xy[str(name)] = xy
    for wd, d in depots_named if depots else ():  # a fleet.json without depots: before pads
        if d not in depots:
            raise FleetDirError(f"{wd}: {quoted(d)}, a depot fleet.json's depots do not give "
                                f"({', '.join(printable(n) for n in depots)})")  # fmt: skip
    return FleetDir(
        path=path, vehicles=tuple(vehicles), map_name=_name(doc.get("map"), f"{summary}: map"),
        depots=depots,
        objective=_name(doc.get("objective"), f"{summary}: objective"),
        total_s=_number(doc.get("total_s"), f"{summary}: total_s"), swaps=swaps, raw=doc,
        swap_s=_number(doc.get("swap_s"), f"{summary}: swap_s"),
        f_total=_number(doc.get("f_total"), f"{summary}: f_total"),
        timing_tolerance_s=_number(doc.get("timing_tolerance_s"),
                                   f"{summary}: timing_tolerance_s"),
        depots_xy=depots_xy,
    )  # fmt: skip

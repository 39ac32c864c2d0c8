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
`mission-v{vehicle}-s{sortie}.plan`); every sortie's file is a plain name inside DIR and exists.
Figures (durations, energies) are kept when present and finite, else None; `"energy_wh": null`
says the plan's map had no battery (`FleetSortie.no_battery`); fields this reader does not
know are left alone. At most `MAX_FLEET_VEHICLES` vehicles (100, `fleet.uavs`' most)
and `MAX_FLEET_SORTIES` sorties in all (1,000; `planner_core.defaults`), checked before any
sortie is read: what follows (`verify DIR/` replays every sortie) grows with them. Reading costs
O(vehicles + sorties).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from lamde_mission.sorties import FLEET_FILE, sortie_file  # the writer's names, one place
from planner_core.defaults import MAX_FLEET_SORTIES, MAX_FLEET_VEHICLES
from planner_core.textio import InputError, quoted, read_json

__all__ = ["FLEET_FILE", "MAX_FLEET_SORTIES", "MAX_FLEET_VEHICLES", "FleetDirError",
           "FleetSortie", "FleetVehicle", "FleetDir", "read_fleet_dir",
           "sortie_file_name"]  # fmt: skip


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


@dataclass(frozen=True)
class FleetVehicle:
    """One vehicle: its number and sorties in flying order (possibly none)."""

    vehicle: int
    sorties: tuple[FleetSortie, ...]
    makespan_s: float | None = None
    #: s after the first vehicle's take-off (0 when fleet.json gives none)
    launch_s: float = 0.0


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


def _latlon(v: Any, where: str) -> tuple[float, float] | None:
    """A position's {"lat", "lon"} (WGS84 degrees), None when absent."""
    if v is None:
        return None
    if not isinstance(v, dict):
        raise FleetDirError(f"{where}: expected an object with lat and lon, got {quoted(v)}")
    lat, lon = _number(v.get("lat"), f"{where}.lat"), _number(v.get("lon"), f"{where}.lon")
    if lat is None or lon is None or not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        raise FleetDirError(f"{where}: expected lat in [-90, 90] and lon in [-180, 180] "
                            "degrees")  # fmt: skip
    return lat, lon


def _offset(v: Any, where: str) -> tuple[float, float] | None:
    """A place's {"east_m", "north_m"} from its depot, None when absent."""
    if not isinstance(v, dict) or ("east_m" not in v and "north_m" not in v):
        return None
    east, north = _number(v.get("east_m"), f"{where}.east_m"), _number(v.get("north_m"),
                                                                         f"{where}.north_m")
    if east is None or north is None:
        raise FleetDirError(f"{where}: expected both east_m and north_m (metres)")
    return east, north


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
            bad JSON, vehicles or sorties out of order or more than `MAX_FLEET_VEHICLES` /
            `MAX_FLEET_SORTIES`, a file outside the directory or missing.
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
    for k, v in enumerate(vs):
        wv = f"{summary}: vehicles[{k}]"
        if not isinstance(v, dict):
            raise FleetDirError(f"{wv}: expected an object")
        number = _index(v.get("vehicle"), f"{wv}.vehicle", k + 1)
        ss = v.get("sorties", [])
        if not isinstance(ss, list):
            raise FleetDirError(f"{wv}.sorties: expected a list")
        sorties = []
        for j, s in enumerate(ss):
            ws = f"{wv}.sorties[{j}]"
            if not isinstance(s, dict):
                raise FleetDirError(f"{ws}: expected an object")
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
            sensors = s.get("sensors", [])
            if not isinstance(sensors, list) or not all(isinstance(x, str) for x in sensors):
                raise FleetDirError(f"{ws}.sensors: expected a list of sensor ids")
            takeoff = _number(s.get("takeoff_s"), f"{ws}.takeoff_s")
            if takeoff is not None and not 0.0 <= takeoff <= MAX_CLOCK_S:
                raise FleetDirError(f"{ws}.takeoff_s: expected seconds in [0, {MAX_CLOCK_S:g}], "
                                    f"got {takeoff:g}")  # fmt: skip
            sorties.append(FleetSortie(
                sortie=sortie, path=fp,
                depot_start=_name(s.get("depot_start"), f"{ws}.depot_start"),
                depot_end=_name(s.get("depot_end"), f"{ws}.depot_end"),
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
            ))  # fmt: skip
        launch = _number(v.get("launch_s"), f"{wv}.launch_s")
        if launch is not None and not 0.0 <= launch <= 1e6:
            raise FleetDirError(f"{wv}.launch_s: expected seconds in [0, 1e6], got {launch:g}")
        vehicles.append(
            FleetVehicle(number, tuple(sorties), _number(v.get("makespan_s"), f"{wv}.makespan_s"),
                         0.0 if launch is None else launch)
        )
    swaps = doc.get("swaps")
    if swaps is not None and (isinstance(swaps, bool) or not isinstance(swaps, int)):
        raise FleetDirError(f"{summary}: swaps: expected a whole number, got {quoted(swaps)}")
    depots_doc = doc.get("depots", {})
    if not isinstance(depots_doc, dict) or len(depots_doc) > MAX_FLEET_SORTIES:
        raise FleetDirError(f"{summary}: depots: expected an object of depot names, got "
                            f"{quoted(depots_doc)}")  # fmt: skip
    depots = {}
    for name, where in depots_doc.items():
        got = _latlon(where, f"{summary}: depots.{name}")
        if got is not None:
            depots[str(name)] = got
    return FleetDir(
        path=path, vehicles=tuple(vehicles), map_name=_name(doc.get("map"), f"{summary}: map"),
        depots=depots,
        objective=_name(doc.get("objective"), f"{summary}: objective"),
        total_s=_number(doc.get("total_s"), f"{summary}: total_s"), swaps=swaps, raw=doc,
        swap_s=_number(doc.get("swap_s"), f"{summary}: swap_s"),
    )  # fmt: skip

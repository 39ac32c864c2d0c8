"""The map file users write: pydantic v2 models for validation, and `Map`, the frozen value inside.

The JSON field names are fixed (other tools already write them). Local frame: metres, x east,
y north, from the geographic `origin`. Every problem found is reported on its own line, naming
the field, so a user can fix a map in one pass.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from planner_core import textio
from planner_core.defaults import (
    MAP_CHOICES,
    MAP_DEFAULTS,
    MAP_LISTS,
    MAX_DEPOTS,
    interval_text,
    number_text,
    obstacle_label,
)
from planner_core.model import energy as _energy
from planner_core.model import pads as _pads
from planner_core.model.geometry import Obstacles, points_inside, rectangle_vertices
from planner_core.model.polygons import clean_polygon, convex_pieces, is_convex

__all__ = [
    "Map",
    "MapError",
    "Depot",
    "PolygonShape",
    "MapFile",
    "load_map",
    "map_json_schema",
    "default_max_hover_points",
    "sub_map_dict",
]

_STRICT = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)

# ----------------------------------------------------------------------------- physical ranges
# Every number of a map has a documented range; the reason is part of the field's description
# (so `lamde-mission schema` shows it) and of the error line. `check` and `plan` both validate
# here, so they agree. The bounds keep the model away from degenerate arithmetic (1e308 sizes,
# flight times that overflow, grids of ~1e12 cells) and inside what MAVLink carries.

#: largest side of the area, m: the local flat frame from one origin and the paper's maps (<=10 km)
MAX_SIDE = 100_000.0
#: largest |coordinate| of any point, m (points must also lie in the area where the model says so)
MAX_COORD = 1_000_000.0
_WHY_COORD = "10x the largest area; beyond it the local flat frame means nothing"
_WHY_SIDE = (
    "the paper's maps are at most 10 km a side; one flat local frame from the origin stays "
    "accurate to 100 km"
)
#: metres: the least circle radius and rectangle side (`obstacles.circles[].radius`,
#: `obstacles.rectangles[].length` / `width`): a radius of 1e-16 m passed and made the sim's
#: clearance NaN, a side of 1e-15 m a degenerate polygon
MIN_OBSTACLE_SIZE = 0.01
_WHY_OBSTACLE_SIZE = ("at least 1 cm: smaller is below any position fix and degenerates the "
                      "geometry; at most 1000 km: larger overflows its arithmetic")


def _ranged(
    default: Any, lo: float | None, hi: float | None, what: str, why: str, *,
    lo_open: bool = False, hi_open: bool = False, sides: tuple[str, str] | None = None,
) -> Any:  # fmt: skip
    """A Field with bounds [lo, hi] (open ends where asked), `why` kept in the description;
    the interval and `sides` (a reason below the range, one above it) kept for the error line
    (`_range_problem`)."""
    kw: dict[str, Any] = {}
    if lo is not None:
        kw["gt" if lo_open else "ge"] = lo
    if hi is not None:
        kw["lt" if hi_open else "le"] = hi
    interval = interval_text(lo, hi, lo_open, hi_open)
    desc = f"{what}; range {interval}: {why}"
    extra = {"x-range-reason": why, "x-range": interval}
    if sides is not None:
        extra["x-range-reason-below"], extra["x-range-reason-above"] = sides
    # strict: a JSON number only (no "2000", no true read as 1), an integer where one is asked
    return Field(default, description=desc, json_schema_extra=extra, strict=True,
                 **kw)  # fmt: skip


#: text without control characters (names and ids are printed in one-line messages)
#: names and ids: no C0 or C1 control characters, DEL, line/paragraph separators or bidi
#: controls (embeddings, overrides, isolates): each could forge a line of a summary or reorder
#: what a terminal shows
_PRINTABLE = r"^[^\x00-\x1f\x7f-\x9f" + "\u2028\u2029\u202a-\u202e\u2066-\u2069" + "]*$"

Coord = Annotated[float, Field(ge=-MAX_COORD, le=MAX_COORD, strict=True,
                               description=f"metres; {_WHY_COORD}")]  # fmt: skip
Point2 = tuple[Coord, Coord]


def _field(path: str) -> Any:
    """The Field of an optional map field: default, bounds and their reason from the table
    `planner_core.defaults.MAP_DEFAULTS` (one place for README, `check` and `plan`)."""
    d = MAP_DEFAULTS[path]
    lo, hi, lo_open, hi_open = d.bounds
    return _ranged(d.value, lo, hi, d.meaning, d.why, lo_open=lo_open, hi_open=hi_open,
                   sides=d.why_sides)


class Origin(BaseModel):
    """WGS84 position of the local (0, 0)."""

    model_config = _STRICT
    # required, range and reason kept as every other bounded field's (a reviewer: lat 200 read
    # "must be less than or equal to 90" where the others read "must be in [a, b]")
    lat: float = _ranged(..., -90.0, 90.0, "WGS84 latitude, degrees",
                         "latitudes end at the poles")
    lon: float = _ranged(..., -180.0, 180.0, "WGS84 longitude, degrees",
                         "longitudes go once round the Earth, east and west of Greenwich")
    alt: float = _ranged(
        0.0, -500.0, 9_000.0, "altitude above mean sea level of the take-off ground, m",
        "ground on Earth lies between the Dead Sea shore (-430 m) and Everest (8849 m)",
    )


class Area(BaseModel):
    """The rectangle [0, width] x [0, height] the hover points must lie in (C1)."""

    model_config = _STRICT
    width: float = _ranged(..., 0.0, MAX_SIDE, "metres along x (east)", _WHY_SIDE, lo_open=True)
    height: float = _ranged(..., 0.0, MAX_SIDE, "metres along y (north)", _WHY_SIDE, lo_open=True)


class Sensor(BaseModel):
    """A ground sensor; `required_data` overrides `radio.required_data` for this sensor."""

    model_config = _STRICT
    id: str = Field(min_length=1, max_length=100, pattern=_PRINTABLE,
                    description="printable text (it is quoted in messages, one line each)")
    x: Coord
    y: Coord
    required_data: float | None = _ranged(
        None, *MAP_DEFAULTS["radio.required_data"].bounds[:2], "Mbit (Q_lambda for this sensor)",
        MAP_DEFAULTS["radio.required_data"].why
    )


class Circle(BaseModel):
    model_config = _STRICT
    x: Coord
    y: Coord
    radius: float = _ranged(..., MIN_OBSTACLE_SIZE, MAX_COORD, "metres", _WHY_OBSTACLE_SIZE)


class Rectangle(BaseModel):
    """A building; `length` lies along its axis rotated `angle_deg` counter-clockwise from east."""

    model_config = _STRICT
    x: Coord
    y: Coord
    length: float = _ranged(..., MIN_OBSTACLE_SIZE, MAX_COORD, "metres", _WHY_OBSTACLE_SIZE)
    width: float = _ranged(..., MIN_OBSTACLE_SIZE, MAX_COORD, "metres", _WHY_OBSTACLE_SIZE)
    angle_deg: float = _ranged(
        0.0, -360.0, 360.0, "degrees", "one turn either way says every direction"
    )


_RING_DOC = (
    "any simple polygon, convex or not: either orientation (reordered), a closing vertex equal "
    "to the first is accepted, vertices closer than 5 mm to the previous one or to the segment "
    "joining their neighbours are removed (noted)"
)


class _HoledPolygon(BaseModel):
    """Any simple polygon (`vertices`, the exterior ring) with optional `holes`; the fields a
    no-fly zone and a polygon footprint share."""

    model_config = _STRICT
    vertices: list[Point2] = Field(description=_RING_DOC)
    holes: list[list[Point2]] = Field([], description="rings inside, where flight is allowed "
                                      "(a courtyard)")  # fmt: skip
    name: str | None = Field(None, max_length=200, pattern=_PRINTABLE,
                             description="label shown in messages, plots and exports")


class NoFlyZone(_HoledPolygon):
    """A no-fly zone: any simple polygon (`vertices`, the exterior ring) with optional `holes`."""


class PolygonObstacle(_HoledPolygon):
    """An obstacle footprint (a building): any simple polygon with optional `holes`."""


class ObstaclesSpec(BaseModel):
    model_config = _STRICT
    circles: list[Circle] = []
    rectangles: list[Rectangle] = []
    no_fly_zones: list[NoFlyZone] = []
    polygons: list[PolygonObstacle] = Field(
        [], description="obstacle footprints of any polygonal shape (buildings)"
    )

    @property
    def count(self) -> int:
        """Obstacles of every kind: circles, rectangles, no-fly zones and polygons.

        Returns:
            Their number, >= 0.
        """
        return (len(self.circles) + len(self.rectangles) + len(self.no_fly_zones)
                + len(self.polygons))


class Battery(BaseModel):
    """One battery (issue 33): its energy and the reserve kept at landing. The energy may
    instead be given as `uav.endurance_s` (hover seconds), with the reserve still here."""

    model_config = _STRICT
    energy_wh: float | None = _field("uav.battery.energy_wh")
    reserve: float = _field("uav.battery.reserve")


class Power(BaseModel):
    """Propulsion power model of Zeng, Xu and Zhang, IEEE Trans. Wireless Commun. 18(4), 2019,
    Eq. (12), with its Table I as defaults (`planner_core.model.energy`, docs/energy.md)."""

    model_config = _STRICT
    blade_profile_w: float = _field("uav.power.blade_profile_w")
    induced_w: float = _field("uav.power.induced_w")
    tip_speed: float = _field("uav.power.tip_speed")
    induced_velocity: float = _field("uav.power.induced_velocity")
    fuselage_drag_ratio: float = _field("uav.power.fuselage_drag_ratio")
    air_density: float = _field("uav.power.air_density")
    rotor_solidity: float = _field("uav.power.rotor_solidity")
    rotor_disc_area: float = _field("uav.power.rotor_disc_area")


class Uav(BaseModel):
    model_config = _STRICT
    altitude: float = _field("uav.altitude")
    max_speed: float = _field("uav.max_speed")
    acceleration: float = _field("uav.acceleration")
    climb_speed: float = _field("uav.climb_speed")
    descent_speed: float = _field("uav.descent_speed")
    max_hover_time: float = _field("uav.max_hover_time")
    max_hover_points: int | None = _field("uav.max_hover_points")
    activation_threshold: float = _field("uav.activation_threshold")
    battery: Battery | None = Field(None, description="one battery's energy and reserve (null: "
                                    "no battery, one flight as before)")  # fmt: skip
    endurance_s: float | None = _field("uav.endurance_s")
    power: Power = Field(Power(), description="propulsion power model (Zeng et al. 2019)")


#: the fields of the map file added for batteries and fleets (issue 33) and the vertical
#: speeds of the take-off and landing: left out of `Map.to_dict` and `Map.summary` unless the
#: file gives them, so older maps read back as before
_UAV_ENERGY_FIELDS = ("battery", "endurance_s", "power", "climb_speed", "descent_speed")


class Radio(BaseModel):
    model_config = _STRICT
    peak_rate: float = _field("radio.peak_rate")
    decay: float = _field("radio.decay")
    bandwidth: float = _field("radio.bandwidth")
    required_data: float = _field("radio.required_data")
    access: Literal["simultaneous", "scheduled"] = Field(
        MAP_CHOICES["radio.access"].value, description=MAP_CHOICES["radio.access"].meaning)


class Objective(BaseModel):
    model_config = _STRICT
    alpha: float = _field("objective.alpha")
    collision_offset: float = _field("objective.collision_offset")
    collision_weight: float = _field("objective.collision_weight")
    goal: Literal["total", "makespan"] = Field(
        MAP_CHOICES["objective.goal"].value, description=MAP_CHOICES["objective.goal"].meaning)


#: pads a depot may list (`Depot.pads`): as many as vehicles fly
MAX_DEPOT_PADS = 100


class Depot(BaseModel):
    """A take-off, landing and battery-swap site (local metres)."""

    model_config = _STRICT
    name: str = Field(min_length=1, max_length=100, pattern=_PRINTABLE,
                      description="printable text, unique among the depots (quoted in messages)")
    x: Coord
    y: Coord
    pads: list[tuple[Coord, Coord]] | None = Field(
        None, max_length=MAX_DEPOT_PADS,
        description="[[x, y], ...] local metres: the depot's pads 2, 3, ... as the crew has "
        "them (pad 1 is the depot itself), in the order the vehicles using the depot take "
        "them; null: on a grid around the depot (planner_core.model.pads); pads it needs "
        "beyond these come from the grid")


class Fleet(BaseModel):
    """UAVs flying at once, their depots, the battery swap time (issue 33) and the least
    distance between two of them in the air."""

    model_config = _STRICT
    uavs: int = _field("fleet.uavs")
    depots: list[Depot] | None = Field(None, min_length=1, max_length=MAX_DEPOTS,
                                       description=MAP_LISTS["fleet.depots"].meaning)
    swap_s: float = _field("fleet.swap_s")
    separation_m: float = _field("fleet.separation_m")
    launch_tolerance_s: float = _field("fleet.launch_tolerance_s")


#: metres: obstacles and no-fly zones are inflated by this much for planning (`safety.clearance`)
DEFAULT_CLEARANCE: float = MAP_DEFAULTS["safety.clearance"].value
#: fraction added to every sensor's required data for planning (`safety.data_margin`)
DEFAULT_DATA_MARGIN: float = MAP_DEFAULTS["safety.data_margin"].value


class Safety(BaseModel):
    """Margins applied to the map before the model sees it (the paper's model is unchanged).

    `clearance` (m): every circle, rectangle and no-fly zone is inflated by it for planning, so
    no leg comes closer to an obstacle; the geofence written to the vehicle keeps the real
    shapes. Near the start, the end or a depot an obstacle of any kind is inflated only as far
    as leaves that point outside it (the take-off and landing are where the map says;
    `Map.obstacle_clearances`). `data_margin`: every
    sensor's required data is planned as (1 + data_margin) x Q_lambda. Sensors themselves may
    lie inside an inflated obstacle: data is collected by radio from wherever the UAV hovers.
    A map with both at 0 is planned exactly as the paper's model states it.
    """

    model_config = _STRICT
    clearance: float = _field("safety.clearance")
    data_margin: float = _field("safety.data_margin")


class Witness(BaseModel):
    """A known feasible plan stored by the map generator."""

    model_config = _STRICT
    hover_points: list[Point2] = Field(max_length=200)
    hover_times: list[Annotated[float, Field(ge=0.0, le=86_400.0, strict=True)]] = Field(
        max_length=200)


class MapFile(BaseModel):
    """The whole map file (JSON)."""

    model_config = _STRICT
    name: str = Field("unnamed", min_length=1, max_length=200, pattern=_PRINTABLE,
                      description="printable text, not empty (as a depot's name or a "
                      "sensor's id; quoted in messages)")
    origin: Origin | None = Field(
        None, description="WGS84 position of (0, 0); needed to write or read a mission (no "
        "default place is assumed)")
    area: Area
    start: Point2
    end: Point2
    sensors: list[Sensor] = Field(min_length=1)
    obstacles: ObstaclesSpec = ObstaclesSpec()
    uav: Uav = Uav()
    radio: Radio = Radio()
    objective: Objective = Objective()
    safety: Safety = Safety()
    fleet: Fleet | None = Field(None, description="UAVs, depots and battery swaps (null: one "
                                "UAV taking off at the start)")  # fmt: skip
    witness: Witness | None = None


class MapError(ValueError):
    """A map that cannot be used; `problems` holds one line per problem, each naming the field."""

    def __init__(self, problems: list[str], notes: list[str] | None = None):
        self.problems = list(problems)
        self.notes = list(notes or [])
        super().__init__("\n".join(self.problems))


#: the most hover points a map may ask for (uav.max_hover_points' upper bound)
MAX_HOVER_POINTS = 200


def default_max_hover_points(width: float, height: float, sensors: int = 0) -> int:
    """I_max for a map that leaves it null: the paper's heuristic (10 on maps up to 5 km a
    side, else 20; Sec. 5.1), raised to one point per two sensors for larger deployments,
    ceil(J / 2), at most `MAX_HOVER_POINTS`. The paper's maps (at most 20 sensors on 5 km, 40
    on 10 km) keep 10 and 20; 160 sensors get 80 (a point in the middle of two or more sensors
    serves them at once; the large generator's witnesses use as many).

    Args:
        width, height: the area's sides (m).
        sensors: J, the map's number of sensors.

    Returns:
        I_max (int, 10..200)."""
    paper = 10 if max(width, height) <= 5000 else 20
    return max(paper, min(MAX_HOVER_POINTS, -(-int(sensors) // 2)))


def map_json_schema() -> dict[str, Any]:
    """JSON Schema (draft 2020-12, named by its `$schema` key) of the map file.

    Returns:
        The schema as JSON-ready data (`MapFile.model_json_schema()` with `$schema` first).
    """
    return {"$schema": "https://json-schema.org/draft/2020-12/schema",
            **MapFile.model_json_schema()}


@dataclass(frozen=True, eq=False)
class PolygonShape:
    """One no-fly zone or polygon obstacle as used: cleaned rings, exterior counter-clockwise,
    holes clockwise (RFC 7946's orientation), in local metres."""

    kind: str  # "no_fly_zone" or "polygon"
    index: int  # position in its list of the map file
    name: str | None
    shell: np.ndarray  # (V, 2)
    holes: tuple[np.ndarray, ...] = ()

    @property
    def convex(self) -> bool:
        """Convex and without holes: the kernel takes it as one polygon.

        Returns:
            True when it has no holes and its shell is convex (`is_convex`).
        """
        return not self.holes and is_convex(self.shell)

    @property
    def label(self) -> str:
        """The shape's name in messages.

        Returns:
            "no-fly-zone k" or "polygon k" (k its index in its list), then its name quoted
            when it has one (`planner_core.defaults.obstacle_label`).
        """
        return obstacle_label(self.kind, self.index, self.name)

    def pieces(self) -> list[np.ndarray]:
        """Convex pieces (V, 2) counter-clockwise, disjoint interiors, union = the shape.

        Returns:
            The pieces' vertex arrays, (V, 2) each, local metres (`convex_pieces`).
        """
        return [v for v, _ in convex_pieces(self.shell, self.holes)]


@dataclass(frozen=True, eq=False)
class Map:
    """A validated map: the file as given (`spec`) plus the arrays the model uses.

    `shapes` holds every no-fly zone then every polygon obstacle, cleaned; `nfz_polygons` the
    no-fly zones' exterior rings (counter-clockwise).
    """

    spec: MapFile
    nfz_polygons: tuple[np.ndarray, ...]
    notes: tuple[str, ...] = field(default=())
    shapes: tuple[PolygonShape, ...] = field(default=())

    # --- scalars in the paper's symbols ---
    @property
    def name(self) -> str:
        """The map's name.

        Returns:
            `spec.name`.
        """
        return self.spec.name

    @property
    def width(self) -> float:
        """The area's side along x (east).

        Returns:
            Metres.
        """
        return self.spec.area.width

    @property
    def height(self) -> float:
        """The area's side along y (north).

        Returns:
            Metres.
        """
        return self.spec.area.height

    @property
    def max_hover_points(self) -> int:
        """I_max in force (the file's value or the default).

        Returns:
            `uav.max_hover_points`, or `default_max_hover_points` for the area and sensors.
        """
        u = self.spec.uav.max_hover_points
        if u is not None:
            return u
        return default_max_hover_points(self.width, self.height, len(self.spec.sensors))

    @cached_property
    def start(self) -> np.ndarray:
        """The mission's start.

        Returns:
            (2,) position, local metres.
        """
        return np.array(self.spec.start, dtype=float)

    @cached_property
    def end(self) -> np.ndarray:
        """The mission's end.

        Returns:
            (2,) position, local metres.
        """
        return np.array(self.spec.end, dtype=float)

    @cached_property
    def sensor_ids(self) -> tuple[str, ...]:
        """The sensors' ids.

        Returns:
            (J,) ids, in the file's order.
        """
        return tuple(s.id for s in self.spec.sensors)

    @cached_property
    def sensors(self) -> np.ndarray:
        """(J, 2) sensor positions.

        Returns:
            (J, 2) positions, local metres, in the file's order.
        """
        return np.array([[s.x, s.y] for s in self.spec.sensors], dtype=float)

    @cached_property
    def required_data(self) -> np.ndarray:
        """(J,) Q_lambda per sensor, Mbit.

        Returns:
            (J,) Mbit: each sensor's `required_data`, else `radio.required_data`.
        """
        q = self.spec.radio.required_data
        return np.array(
            [s.required_data if s.required_data is not None else q for s in self.spec.sensors]
        )

    @cached_property
    def rectangle_polygons(self) -> tuple[np.ndarray, ...]:
        """The rectangles' corners.

        Returns:
            One (4, 2) counter-clockwise corner array per rectangle, local metres
            (`rectangle_vertices`).
        """
        return tuple(
            rectangle_vertices(r.x, r.y, r.length, r.width, r.angle_deg)
            for r in self.spec.obstacles.rectangles
        )

    @cached_property
    def obstacles(self) -> Obstacles:
        """All obstacles in the geometry kernel's packed form: circles; rectangles, convex
        no-fly zones and convex polygon obstacles as polygons; the other shapes as regions.

        Returns:
            The packed `Obstacles`.
        """
        return _pack(self.spec, self.shapes)

    # --- batteries, power and fleets (issue 33; docs/energy.md) ---
    @property
    def has_battery(self) -> bool:
        """The map gives a battery (`uav.battery.energy_wh` or `uav.endurance_s`).

        Returns:
            True when either is given.
        """
        u = self.spec.uav
        return u.endurance_s is not None or (u.battery is not None
                                             and u.battery.energy_wh is not None)  # fmt: skip

    @property
    def has_fleet(self) -> bool:
        """The map gives a `fleet` section (UAVs, depots, swap time).

        Returns:
            True when it does.
        """
        return self.spec.fleet is not None

    @cached_property
    def power(self) -> _energy.PowerParams:
        """The propulsion power model's parameters in force (`uav.power`, defaults: Zeng et
        al. 2019 Table I), for `planner_core.model.energy`.

        Returns:
            The `PowerParams` (`PowerParams.from_spec(uav.power)`).
        """
        return _energy.PowerParams.from_spec(self.spec.uav.power)

    @property
    def battery_wh(self) -> float | None:
        """A full battery's energy (Wh): `uav.battery.energy_wh`, or `uav.endurance_s` x P(0);
        None without a battery.

        Returns:
            Wh, or None without a battery.
        """
        u = self.spec.uav
        e = u.battery.energy_wh if u.battery is not None else None
        return _energy.battery_energy_wh(e, u.endurance_s, self.power)

    @property
    def battery_reserve(self) -> float:
        """Fraction of the battery kept at landing (`uav.battery.reserve`, default 0.2).

        Returns:
            The fraction, also without a battery (then the default).
        """
        b = self.spec.uav.battery
        return float(b.reserve if b is not None else MAP_DEFAULTS["uav.battery.reserve"].value)

    @property
    def usable_energy_wh(self) -> float | None:
        """Energy one sortie may spend (Wh): battery x (1 - reserve); None without a battery.

        Returns:
            Wh, or None without a battery.
        """
        full = self.battery_wh
        return None if full is None else _energy.usable_energy_wh(full, self.battery_reserve)

    @property
    def uavs(self) -> int:
        """UAVs flying at once (`fleet.uavs`, default 1).

        Returns:
            The count.
        """
        f = self.spec.fleet
        return int(f.uavs if f is not None else MAP_DEFAULTS["fleet.uavs"].value)

    @property
    def swap_s(self) -> float:
        """Seconds a battery swap takes (`fleet.swap_s`, default 300).

        Returns:
            Seconds.
        """
        f = self.spec.fleet
        return float(f.swap_s if f is not None else MAP_DEFAULTS["fleet.swap_s"].value)

    @property
    def separation_m(self) -> float:
        """Metres: the least 3D distance between two vehicles in the air
        (`fleet.separation_m`, default 30), judged by verify's SEPARATION and kept by plan's
        staggered launches (`lamde_mission.launches.stagger`).

        Returns:
            Metres.
        """
        f = self.spec.fleet
        return float(f.separation_m if f is not None
                     else MAP_DEFAULTS["fleet.separation_m"].value)  # fmt: skip

    @property
    def launch_tolerance_s(self) -> float:
        """Seconds each sortie may take off early or late with SEPARATION and LINKS holding
        (`fleet.launch_tolerance_s`, default 30): plan's staggered launches keep it
        (`lamde_mission.launches.stagger`), verify's TIMING judges it.

        Returns:
            Seconds.
        """
        f = self.spec.fleet
        return float(f.launch_tolerance_s if f is not None
                     else MAP_DEFAULTS["fleet.launch_tolerance_s"].value)  # fmt: skip

    @cached_property
    def depots(self) -> tuple[Depot, ...]:
        """The take-off, landing and swap sites in force: `fleet.depots`, or one depot named
        `DEFAULT_DEPOT` at the map's start (a sortie may then land at the map's end).

        Returns:
            The `Depot`s, in the file's order.
        """
        f = self.spec.fleet
        if f is not None and f.depots:
            return tuple(f.depots)
        x, y = self.spec.start
        return (Depot(name=DEFAULT_DEPOT, x=x, y=y),)

    @cached_property
    def sortie_sites(self) -> tuple[tuple[str, ...], np.ndarray, tuple[int, ...]]:
        """Where sorties take off and land, as the sortie planner has them
        (`planner_core.fleet.FleetSettings`): (names, positions (D, 2) m read-only, the indices
        a vehicle's first sortie may leave). With `fleet.depots`: those, each a take-off
        site; without: `DEFAULT_DEPOT` at the start, where every vehicle takes off, and, when
        the end differs, `END_DEPOT` at the end, a landing site (a vehicle takes off where it
        landed, so a take-off site only for one that landed there).

        Returns:
            (names (D,), positions (D, 2) local metres read-only, first-sortie depot indices:
            all with `fleet.depots`, else (0,)).
        """
        names = [d.name for d in self.depots]
        xy = [[d.x, d.y] for d in self.depots]
        given = self.spec.fleet is not None and bool(self.spec.fleet.depots)
        if not given and not np.allclose(self.start, self.end) and END_DEPOT not in names:
            names.append(END_DEPOT)
            xy.append([float(self.end[0]), float(self.end[1])])
        a = np.asarray(xy, dtype=float).reshape(-1, 2)
        a.flags.writeable = False
        return tuple(names), a, tuple(range(len(names))) if given else (0,)

    @cached_property
    def depot_xy(self) -> np.ndarray:
        """(D, 2) depot positions, metres, in `depots` order (read-only).

        Returns:
            (D, 2) read-only array, local metres (no `END_DEPOT`: see `sortie_sites`).
        """
        a = np.array([[d.x, d.y] for d in self.depots], dtype=float)
        a.flags.writeable = False
        return a

    @property
    def vehicle_pads(self) -> np.ndarray:
        """The pads of each sortie site (`planner_core.model.pads`; the vehicles a plan sends
        to a site take them in the order of their numbers, `pad_ranks`): index 0 (pad 1, as
        `check` numbers them) is the site itself, the others lie `fleet.separation_m` +
        `PAD_MARGIN_M` apart on a grid aligned with east and north around it, inside the
        area, at least `PAD_CLEAR_M` (or the map's clearance, where larger) from every
        obstacle, and reached from the site by a straight leg clear of the planning map's
        (inflated) obstacles.

        Returns:
            (V, D, 2) read-only, local metres: V = `uavs`, D the sites of `sortie_sites`
            (`pads_for(uavs)`).

        Raises:
            ValueError: a site without room for every vehicle's pad, naming it.
        """
        return self.pads_for(int(self.uavs))

    def pads_for(self, vehicles: int) -> np.ndarray:
        """`vehicle_pads` laid out for `vehicles` vehicles (cached per count, a layout without
        room too): the map's own
        layout at `fleet.uavs`; a larger count is for replaying a plan of more vehicles than
        the map flies (which `verify`'s UAVS fails), each then at a pad of its own.

        Args:
            vehicles: V >= 1.

        Returns:
            (V, D, 2) read-only, local metres.

        Raises:
            ValueError: a site without room for every vehicle's pad, naming it.
        """
        cache = self.__dict__.setdefault("_pads_for", {})
        got = cache.get(int(vehicles))
        if isinstance(got, ValueError):  # no room, found before: the same line again
            raise ValueError(*got.args)
        if got is not None:
            return got
        from planner_core.model.geometry import overlap_lengths

        names, sites, _ = self.sortie_sites
        W, H = self.spec.area.width, self.spec.area.height
        obstacles = self.planning_map().obstacles

        keep = max(_pads.PAD_CLEAR_M, float(self.spec.safety.clearance))

        def free(site: np.ndarray, pads: np.ndarray) -> np.ndarray:
            inside = ((pads[:, 0] >= 0) & (pads[:, 0] <= W) & (pads[:, 1] >= 0)
                      & (pads[:, 1] <= H))  # fmt: skip
            gap = _edge_distances(pads, self.spec, self.shapes)
            legs = overlap_lengths(np.broadcast_to(site, pads.shape), pads, obstacles)
            return np.select([~inside, gap <= 0.0, (gap < keep) | points_inside(pads, obstacles),
                              legs > _pads.CLEAR_M],
                             [_pads.OUTSIDE, _pads.INSIDE, _pads.NEAR, _pads.BEHIND], _pads.FREE)

        spacing = float(self.separation_m) + _pads.PAD_MARGIN_M
        given = {d.name: [tuple(p) for p in d.pads] for d in self.depots if d.pads}
        try:
            out = _pads.pad_layout(sites, int(vehicles), spacing, free, names=tuple(names),
                                   given=[given.get(n, []) for n in names])
        except ValueError as exc:  # check asks several times (PADS, its pads line, --json)
            cache[int(vehicles)] = exc
            raise
        out.flags.writeable = False
        cache[int(vehicles)] = out
        return out

    @property
    def goal(self) -> str:
        """What several sorties minimise (`objective.goal`): "total" or "makespan".

        Returns:
            "total" or "makespan".
        """
        return self.spec.objective.goal

    # --- safety margins (a transformation of the map; see `Safety`) ---
    @cached_property
    def obstacle_labels(self) -> tuple[str, ...]:
        """A label per obstacle, in `obstacle_clearances`' order, as `verify` names it:
        "circle k", "rectangle k", "no-fly-zone k 'name'", "polygon k 'name'" (k the index in
        its list of the map; the name where the map gives one: `defaults.obstacle_label`).

        Returns:
            One label per obstacle, circles, rectangles, no-fly zones, then polygons.
        """
        return _obstacle_labels(self.spec)

    @cached_property
    def obstacle_clearances(self) -> tuple[float, ...]:
        """Clearance in force per obstacle (circles, rectangles, no-fly zones, polygons; metres):
        `safety.clearance`, reduced where the start, the end or a depot is closer than that to
        the obstacle, so the inflated obstacle (`planning_map`) leaves that point outside it:
        a circle down to that distance less `CLEARANCE_PAD`, any other shape less
        `CLEARANCE_PAD` + `CLEARANCE_SLACK` (its inflated corners are outer polygons, see
        `outer_offset`); at least 0.

        Returns:
            One clearance (m, >= 0) per obstacle, in `obstacle_labels`' order.
        """
        return tuple(c for c, _ in self._inflation)

    @cached_property
    def _inflation(self) -> tuple[tuple[float, float], ...]:
        """Per obstacle, in `obstacle_clearances`' order: (clearance in force, the largest
        overshoot factor its inflated polygon may have: `OFFSET_OVERSHOOT`, or less where a
        start, end or depot lies within reach of its corners' outer polygons, so the inflated
        polygon keeps that point outside; 1 for circles, inflated exactly)."""
        import shapely

        c = float(self.spec.safety.clearance)
        shapes = _obstacle_polygons(self)
        if c <= 0.0 or not shapes:
            return tuple((0.0, 1.0) for _ in shapes)
        # the map's depots take off and land too: inflation stops short of them as well
        given = self.spec.fleet.depots if self.spec.fleet is not None else None
        sites = np.array([self.spec.start, self.spec.end, *[(d.x, d.y) for d in given or ()]],
                         dtype=float)  # fmt: skip
        ends = shapely.points(sites)
        out = []
        nc = len(self.spec.obstacles.circles)
        for k, poly in enumerate(shapes):
            if k < nc:  # a circle: its exact distance (the shape above is a polygon inside it)
                o = self.spec.obstacles.circles[k]
                d = float(np.min(np.hypot(sites[:, 0] - o.x, sites[:, 1] - o.y))) - o.radius
                out.append((max(min(c, d - CLEARANCE_PAD), 0.0), 1.0))
                continue
            d = float(np.min(shapely.distance(ends, poly)))
            if (c + CLEARANCE_PAD) * OFFSET_OVERSHOOT <= d:
                out.append((c, OFFSET_OVERSHOOT))
                continue
            cl = max(min(c, d - CLEARANCE_PAD - CLEARANCE_SLACK), 0.0)
            # the inflated polygon reaches at most (cl + pad) x f: half the slack short of d
            reach = d - 0.5 * CLEARANCE_SLACK
            out.append((cl, min(OFFSET_OVERSHOOT, reach / (cl + CLEARANCE_PAD))))
        return tuple(out)

    def with_origin(self, lat: float, lon: float, alt: float = 0.0) -> Map:
        """This map placed at (lat, lon, alt) (what `--origin LAT,LON[,ALT]` does).

        Args:
            lat: WGS84 latitude of the local (0, 0), degrees (-90..90).
            lon: WGS84 longitude of the local (0, 0), degrees (-180..180).
            alt: altitude above mean sea level of the take-off ground, m (-500..9000).

        Returns:
            A new, validated Map (`load_map`) with that origin.

        Raises:
            MapError: coordinates out of range.
        """
        d = self.spec.model_dump(mode="json")
        _drop_unset_energy_fields(self.spec, d)
        d["origin"] = {"lat": lat, "lon": lon, "alt": alt}
        return load_map(d)

    def planning_map(self) -> Map:
        """The map the optimiser plans on: obstacles inflated by their clearance (plus
        `CLEARANCE_PAD`; circles exactly, other shapes by `outer_offset`, which holds every
        point that near and reaches at most `OFFSET_OVERSHOOT` times as far, never as far as
        a start, end or depot), rectangles turned into polygon obstacles, every sensor's
        required data times (1 + data_margin), safety margins then 0. Returns `self` when both
        margins are 0, so such a map is planned and scored exactly as before.

        Returns:
            The planning Map (built once, then cached on this map), or `self`.
        """
        cached = self.__dict__.get("_planning_map")
        if cached is not None:
            return cached
        sf = self.spec.safety
        if sf.clearance <= 0.0 and sf.data_margin <= 0.0:
            return self
        d = self.spec.model_dump(mode="json")
        _drop_unset_energy_fields(self.spec, d)  # the planning map gives what the map gives
        d.pop("witness", None)
        d["safety"] = {"clearance": 0.0, "data_margin": 0.0}
        q = self.required_data * (1.0 + float(sf.data_margin))
        for s, req in zip(d["sensors"], q, strict=True):
            s["required_data"] = float(req)
        cl = self.obstacle_clearances
        obs = self.spec.obstacles
        nc, nr, nz = len(obs.circles), len(obs.rectangles), len(obs.no_fly_zones)
        d["obstacles"]["circles"] = [
            {"x": c.x, "y": c.y, "radius": c.radius + (cl[k] + CLEARANCE_PAD if cl[k] > 0 else 0)}
            for k, c in enumerate(obs.circles)
        ]
        shapes = _obstacle_polygons(self)

        def grown(k: int, name: str | None) -> dict[str, Any]:
            poly = shapes[k]
            if cl[k] > 0.0:
                poly = outer_offset(poly, cl[k] + CLEARANCE_PAD, self._inflation[k][1])
            # the rings' coordinates as lists of [x, y] (one array each, not a tuple per vertex)
            out: dict[str, Any] = {"vertices": np.asarray(poly.exterior.coords)[:-1].tolist()}
            holes = [np.asarray(ring.coords)[:-1].tolist() for ring in poly.interiors]
            if holes:
                out["holes"] = holes
            if name is not None:
                out["name"] = name
            return out

        # rectangles become polygon obstacles (a rounded rectangle is no rectangle), in order
        d["obstacles"]["rectangles"] = []
        d["obstacles"]["no_fly_zones"] = [grown(nc + nr + k, z.name)
                                          for k, z in enumerate(obs.no_fly_zones)]
        d["obstacles"]["polygons"] = (
            [grown(nc + k, None) for k in range(nr)]
            + [grown(nc + nr + nz + k, z.name) for k, z in enumerate(obs.polygons)]
        )  # fmt: skip
        # the start and end may lie on an inflated edge: inflation stops there (obstacle_clearances)
        # and the input limits are the user's file's, not this map's: inflating a polygon
        # adds arc vertices at its corners (up to twice as many on a finely drawn curve)
        pm = _load_map(d, end_gap=0.0, sized=False)
        self.__dict__["_planning_map"] = pm
        return pm

    def to_dict(self) -> dict[str, Any]:
        """The map as JSON-ready data (polygons cleaned, exteriors counter-clockwise).

        Returns:
            The map file's fields as a dict; `polygons` and `witness` left out when empty, and
            the battery, power, fleet, separation and goal fields the file did not give.
        """
        d = self.spec.model_dump(mode="json", exclude_none=False)
        obs = d["obstacles"]
        for sh in self.shapes:
            entry: dict[str, Any] = {"vertices": sh.shell.tolist()}
            if sh.holes:
                entry["holes"] = [h.tolist() for h in sh.holes]
            if sh.name is not None:
                entry["name"] = sh.name
            key = "no_fly_zones" if sh.kind == "no_fly_zone" else "polygons"
            obs[key][sh.index] = entry
        if not obs["polygons"]:
            del obs["polygons"]
        if d.get("witness") is None:
            d.pop("witness", None)
        _drop_unset_energy_fields(self.spec, d)
        return d

    def summary(self) -> dict[str, Any]:
        """Counts, area, I_max and the defaults in force, for `lamde-mission check`.

        Returns:
            JSON-ready dict: name, area_m, origin, start, end, the counts of sensors and
            obstacles, I_max (and whether it is the default), the uav, radio, objective and
            safety settings, total_required_data_mbit, has_witness, then the battery, power
            and fleet entries where the map gives them.
        """
        s = self.spec
        return {
            "name": s.name,
            "area_m": [s.area.width, s.area.height],
            "origin": None if s.origin is None else s.origin.model_dump(),
            "start": list(s.start),
            "end": list(s.end),
            "sensors": len(s.sensors),
            "circles": len(s.obstacles.circles),
            "rectangles": len(s.obstacles.rectangles),
            "no_fly_zones": len(s.obstacles.no_fly_zones),
            "polygons": len(s.obstacles.polygons),
            "max_hover_points": self.max_hover_points,
            "max_hover_points_default": s.uav.max_hover_points is None,
            "uav": s.uav.model_dump(exclude=set(_UAV_ENERGY_FIELDS)),
            "radio": s.radio.model_dump(),
            "objective": s.objective.model_dump(exclude={"goal"}),
            "safety": s.safety.model_dump(),
            "total_required_data_mbit": float(self.required_data.sum()),
            "has_witness": s.witness is not None,
            **self._energy_summary(),
        }

    def _energy_summary(self) -> dict[str, Any]:
        """`summary`'s battery, power and fleet entries, present only when the map gives a
        battery or a fleet (older maps summarise as before)."""
        if not (self.has_battery or self.has_fleet):
            return {}
        u = self.spec.uav
        return {
            "battery": None if not self.has_battery else {
                "energy_wh": self.battery_wh, "reserve": self.battery_reserve,
                "usable_wh": self.usable_energy_wh, "endurance_s": u.endurance_s,
            },
            "power": {**u.power.model_dump(), "hover_w": self.power.hover_w},
            "fleet": {"uavs": self.uavs, "swap_s": self.swap_s,
                      "separation_m": self.separation_m,
                      "launch_tolerance_s": self.launch_tolerance_s,
                      "depots": [d.model_dump() for d in self.depots],
                      "depots_default": not (self.has_fleet and self.spec.fleet.depots)},
            "goal": self.goal,
        }  # fmt: skip


#: the name of the one depot a map without `fleet.depots` has, at its start
DEFAULT_DEPOT = "home"
#: the name of the landing site at the map's end, when the map gives no `fleet.depots` and
#: its end is not its start (a sortie may land there: `Map.sortie_sites`)
END_DEPOT = "end"


def sub_map_dict(
    m: Any,
    start: np.ndarray,
    end: np.ndarray,
    required: np.ndarray,
    *,
    keep: np.ndarray | None = None,
    name: str | None = None,
    box: tuple[np.ndarray, np.ndarray] | None = None,
) -> dict[str, Any]:
    """The map file of a part of map m's work: its start and end moved to `start` and `end`
    and each sensor's required data set to `required` (user units, before the data margin; 0:
    the part need not serve it), its witness and fleet left out. A fleet's sortie
    (`planner_core.fleet`, there `sortie_map_dict`) and a window of a plan
    (`planner_core.pipeline.windows`) are planned on such maps.

    Args:
        m: the loaded map; start, end (2,) m.
        required: (J,) Mbit per sensor.
        keep: sensors (J,) bool to keep in the map (default all: what storage and the sim need
            for C3 over every sensor in range).
        name: the map's name (default m's).
        box: (lo (2,), hi (2,)) m: only the obstacles whose bounding box meets this box are
            kept (a circle's by its radius, a rectangle's by a circle of its diagonal about
            its centre, a polygon's by its vertices); None: every obstacle.

    Returns:
        A map dict (`load_map` reads it). Cost: O(J + obstacles).
    """
    d = m.to_dict()
    d.pop("witness", None)
    d.pop("fleet", None)
    d["start"] = [float(start[0]), float(start[1])]
    d["end"] = [float(end[0]), float(end[1])]
    sensors = []
    for j, s in enumerate(d["sensors"]):
        if keep is not None and not keep[j]:
            continue
        s = dict(s)
        s["required_data"] = float(max(required[j], 0.0))
        sensors.append(s)
    d["sensors"] = sensors
    if box is not None:
        lo, hi = (np.asarray(b, dtype=float).reshape(2) for b in box)

        def meets(x0: float, y0: float, x1: float, y1: float) -> bool:
            return bool(x1 >= lo[0] and x0 <= hi[0] and y1 >= lo[1] and y0 <= hi[1])

        def around(x: float, y: float, r: float) -> bool:  # the box of a disc
            return meets(x - r, y - r, x + r, y + r)

        def ring(o: dict[str, Any]) -> bool:
            v = np.asarray(o["vertices"], dtype=float).reshape(-1, 2)
            return meets(*v.min(axis=0), *v.max(axis=0))

        obs = d["obstacles"]
        obs["circles"] = [c for c in obs.get("circles", [])
                          if around(c["x"], c["y"], c["radius"])]
        obs["rectangles"] = [r for r in obs.get("rectangles", [])
                             if around(r["x"], r["y"], math.hypot(r["length"], r["width"]))]
        for key in ("no_fly_zones", "polygons"):
            if key in obs:
                obs[key] = [z for z in obs[key] if ring(z)]
    if name is not None:
        d["name"] = name
    return d


def _drop_unset_energy_fields(spec: MapFile, d: dict[str, Any]) -> None:
    """Remove from the dumped map `d` the battery, power, fleet, separation and goal fields
    the file did not give (so `Map.to_dict` of a map without them is what it was before issue
    33, and before `fleet.separation_m`)."""
    for key in _UAV_ENERGY_FIELDS:
        if key not in spec.uav.model_fields_set or d["uav"].get(key) is None:
            d["uav"].pop(key, None)
    if "goal" not in spec.objective.model_fields_set:
        d["objective"].pop("goal", None)
    if spec.fleet is None:
        d.pop("fleet", None)
    else:
        for key in ("separation_m", "launch_tolerance_s"):
            if key not in spec.fleet.model_fields_set:
                d["fleet"].pop(key, None)


#: metres added to every non-zero clearance when inflating: covers where a stored mission's
#: points may lie (MAVLink's 1e-7 degree grid is ~1.1 cm), so the real clearance is kept
CLEARANCE_PAD = 0.05
#: metres an inflated polygon (not a circle) stops short of a start, end or depot closer to
#: it than the clearance, beyond `CLEARANCE_PAD`: room for its corners' outer polygons, which
#: then end half of it short of that point (`Map._inflation`); a leg keeps at least the
#: point's distance less 1 cm, and less storage's < 8 mm, within the sim's CLEAR tolerance, 2 cm
CLEARANCE_SLACK = 0.01
#: the most an inflated polygon (`outer_offset`) reaches beyond its clearance, as a factor:
#: 1 / cos(pi / 16), ~2 % (the corners' arcs as outer polygons of at most pi / 8 per segment)
OFFSET_OVERSHOOT = 1.0 / math.cos(math.pi / 16.0)


def outer_offset(poly: Any, r: float, overshoot: float = OFFSET_OVERSHOOT) -> Any:
    """The shape `poly` grown by `r` metres (its Minkowski sum with a disc), as a polygon that
    contains the exact offset and exceeds it by a bounded amount.

    GEOS's buffer is the exact offset but at the arcs about the shape's outward corners, where
    its chords (vertices on the arc) cut inside it. Each such corner's sector, between the
    normals of its two edges, is therefore added as an outer polygon: segments tangent to the
    arc (so the arc lies inside), each spanning at most 2 acos(1 / overshoot), whose vertices
    lie r x overshoot from the corner. So every point within r of the shape is in the result,
    and every point of the result lies within r x `overshoot` of the shape: the excess over r
    is at most r x (overshoot - 1) (~2 % by default), found only at outward corners (straight
    edges and inward corners are offset exactly).

    The same polygon as `_outer_offset_reference`, to the bit (tests): the corners' outer
    polygons are the same points (`_fans`), built together. Cost per polygon of V vertices:
    O(V) array work and one union of its buffer with up to V outer polygons (GEOS).

    Args:
        poly: a shapely Polygon (holes allowed).
        r: the offset, m (> 0).
        overshoot: the largest factor allowed, > 1 (default `OFFSET_OVERSHOOT`).

    Returns:
        A shapely Polygon, exterior counter-clockwise, collinear vertices removed.
    """
    from shapely.geometry.polygon import orient

    half = math.acos(1.0 / max(float(overshoot), 1.0 + 1e-12))  # the widest half segment
    poly = orient(poly, 1.0)  # the shape on the left of every ring, the offset on the right
    parts = [poly.buffer(r, join_style="bevel")]
    for ring in (poly.exterior, *poly.interiors):
        v = np.asarray(ring.coords, dtype=float)[:-1]
        e = np.concatenate((v[1:], v[:1])) - v  # edge k: v[k] -> v[k + 1]
        ang = np.arctan2(e[:, 1], e[:, 0])
        turn = (ang - np.concatenate((ang[-1:], ang[:-1])) + math.pi) % (2.0 * math.pi) - math.pi
        ks = np.flatnonzero(turn > 0.0)  # left turns (at v[k]): an arc on the right
        if len(ks):
            parts += list(_fans(v[ks], r, ang[ks - 1] - math.pi / 2.0, turn[ks], half))
    return _offset_union(parts, poly, r)


def _offset_union(parts: list[Any], poly: Any, r: float) -> Any:
    """`outer_offset`'s last step (and its reference's): the union of the buffer and the
    corners' outer polygons, its largest piece, without the rings the union leaves where its
    pieces meet, counter-clockwise and without collinear vertices."""
    import shapely
    from shapely.geometry.polygon import orient

    grown = shapely.union_all(parts)
    if grown.geom_type != "Polygon":  # pieces touching only at a point: keep the largest
        grown = max(grown.geoms, key=lambda g: g.area)
    # a hole of the offset holds points farther than r from the shape; a ring the union left
    # where its pieces meet (rounding: no area, or all of it within r) is no hole
    holes = [h for h in grown.interiors if (hp := shapely.Polygon(h)).area > 0.0
             and poly.distance(hp.representative_point()) > r]  # fmt: skip
    grown = shapely.Polygon(grown.exterior, holes)
    return shapely.simplify(orient(grown, 1.0), 0.0)  # drop collinear vertices


def _fan(c: np.ndarray, r: float, start: float, sweep: float, half: float) -> Any:
    """The outer polygon of the sector of radius r about c from angle `start` sweeping `sweep`
    radians (> 0) counter-clockwise: c, the arc's ends, and between them the corners of
    segments tangent to the arc, each spanning at most 2 x `half` (widened by 1e-9 rad each
    way, so it overlaps the buffer beside it: no sliver between them)."""
    import shapely

    segs = max(1, math.ceil(sweep / (2.0 * half) - 1e-9))
    step = sweep / segs
    mid = start + step * (np.arange(segs) + 0.5)
    far = r / math.cos(step / 2.0)
    pts = [c, c + r * np.array([math.cos(start), math.sin(start)])]
    pts += list(c + far * np.column_stack([np.cos(mid), np.sin(mid)]))
    pts.append(c + r * np.array([math.cos(start + sweep), math.sin(start + sweep)]))
    return shapely.Polygon(np.asarray(pts))


def _outer_offset_reference(poly: Any, r: float, overshoot: float = OFFSET_OVERSHOOT) -> Any:
    """`outer_offset` building each corner's outer polygon on its own (`_fan`), the
    reference it equals to the bit (tests). One shapely polygon built per outward corner."""
    from shapely.geometry.polygon import orient

    half = math.acos(1.0 / max(float(overshoot), 1.0 + 1e-12))  # the widest half segment
    poly = orient(poly, 1.0)  # the shape on the left of every ring, the offset on the right
    parts = [poly.buffer(r, join_style="bevel")]
    for ring in (poly.exterior, *poly.interiors):
        v = np.asarray(ring.coords, dtype=float)[:-1]
        e = np.roll(v, -1, axis=0) - v  # edge k: v[k] -> v[k + 1]
        ang = np.arctan2(e[:, 1], e[:, 0])
        turn = (ang - np.roll(ang, 1) + math.pi) % (2.0 * math.pi) - math.pi  # at v[k]
        for k in np.flatnonzero(turn > 0.0):  # a left turn: an arc on the right
            parts.append(_fan(v[k], r, ang[k - 1] - math.pi / 2.0, float(turn[k]), half))
    return _offset_union(parts, poly, r)


def _fans(c: np.ndarray, r: float, start: np.ndarray, sweep: np.ndarray,
          half: float) -> np.ndarray:
    """`_fan` for K corners at once: c (K, 2), start and sweep (K,); the same points, float
    for float (the same operations on the same numbers: sums and products element by element,
    `math.cos` / `math.sin` of each scalar, `np.cos` / `np.sin` of each corner's own `mid`
    array), as K shapely polygons made in one call. O(K + segments) array work."""
    import shapely

    starts, sweeps = start.tolist(), sweep.tolist()
    segs = [max(1, math.ceil(sw / (2.0 * half) - 1e-9)) for sw in sweeps]
    steps = [sw / n for sw, n in zip(sweeps, segs, strict=True)]
    far = np.array([r / math.cos(st / 2.0) for st in steps])
    n = np.array(segs, dtype=np.int64)
    first = np.cumsum(n) - n  # where each corner's segments start
    local = np.arange(int(n.sum())) - np.repeat(first, n)
    mid = np.repeat(start, n) + np.repeat(np.array(steps), n) * (local + 0.5)
    bounds = np.concatenate(([0], np.cumsum(n))).tolist()
    cos = np.concatenate([np.cos(mid[a:b]) for a, b in zip(bounds, bounds[1:], strict=False)])
    sin = np.concatenate([np.sin(mid[a:b]) for a, b in zip(bounds, bounds[1:], strict=False)])
    K = len(starts)
    size = n + 3  # the centre, the arc's start, the segments' corners, the arc's end
    row0 = np.cumsum(size) - size
    pts = np.empty((int(size.sum()), 2))
    pts[row0] = c
    ends = np.array([[math.cos(s), math.sin(s), math.cos(s + w), math.sin(s + w)]
                     for s, w in zip(starts, sweeps, strict=True)]).reshape(K, 4)
    pts[row0 + 1] = c + r * ends[:, 0:2]
    rows = np.repeat(row0 + 2, n) + local
    cf = np.repeat(c, n, axis=0)
    ff = np.repeat(far, n)
    pts[rows, 0] = cf[:, 0] + ff * cos
    pts[rows, 1] = cf[:, 1] + ff * sin
    pts[row0 + 2 + n] = c + r * ends[:, 2:4]
    rings = shapely.linearrings(pts, indices=np.repeat(np.arange(K), size))
    return shapely.polygons(rings)


def _obstacle_polygons(m: Map) -> list[Any]:
    """Circles (as exact-enough shapely buffers), rectangles, no-fly zones and polygon
    obstacles, in that order (the sim's order, `sim.obstacles.obstacle_shapes`)."""
    from shapely.geometry import Point, Polygon

    obs = m.spec.obstacles
    out: list[Any] = [Point(c.x, c.y).buffer(c.radius, quad_segs=64) for c in obs.circles]
    out += [Polygon(v) for v in m.rectangle_polygons]
    out += [Polygon(z.vertices, z.holes) for z in obs.no_fly_zones]
    out += [Polygon(z.vertices, z.holes) for z in obs.polygons]
    return out


def _obstacle_labels(spec: MapFile) -> tuple[str, ...]:
    """`Map.obstacle_labels` of the map file `spec`: circles, rectangles, no-fly zones, then
    polygons, each as `defaults.obstacle_label` names it. Cost: O(obstacles)."""
    obs = spec.obstacles
    return tuple([obstacle_label("circle", k) for k in range(len(obs.circles))]
                 + [obstacle_label("rectangle", k) for k in range(len(obs.rectangles))]
                 + [obstacle_label("no_fly_zone", k, z.name)
                    for k, z in enumerate(obs.no_fly_zones)]
                 + [obstacle_label("polygon", k, z.name)
                    for k, z in enumerate(obs.polygons)])  # fmt: skip


def _holding(xy: tuple[float, float], spec: MapFile, shapes: tuple[PolygonShape, ...]) -> str:
    """The obstacles that hold the point `xy` (m), as `verify` names them ("polygon 0 'barn'",
    "circle 1, rectangle 0"; `_obstacle_labels`), for a point the kernel found inside one
    (`points_inside`); "an obstacle or no-fly zone" should shapely's closed test find none.
    Cost: O(obstacles) shapely tests, for the few points found inside."""
    from shapely.geometry import Point, Polygon

    p = Point(float(xy[0]), float(xy[1]))
    obs = spec.obstacles
    held = [obstacle_label("circle", k) for k, c in enumerate(obs.circles)
            if math.hypot(p.x - c.x, p.y - c.y) < c.radius]  # fmt: skip
    held += [obstacle_label("rectangle", k) for k, r in enumerate(obs.rectangles)
             if Polygon(rectangle_vertices(r.x, r.y, r.length, r.width, r.angle_deg)).contains(p)]
    # the cleaned shapes, no-fly zones then polygons, as the kernel holds them
    held += [sh.label for sh in shapes if Polygon(sh.shell, sh.holes).contains(p)]
    return ", ".join(held) if held else "an obstacle or no-fly zone"


def _nearest_label(xy: tuple[float, float], spec: MapFile,
                   shapes: tuple[PolygonShape, ...]) -> str:
    """The obstacle whose edge is nearest the point `xy` (m), as `verify` names it ("circle
    0", "polygon 0 'barn'"; `_holding`'s labels), for a point found too close to one
    (`_edge_distances`); "an obstacle" when there is none. Cost: O(obstacles) shapely
    distances, for the few points found too close."""
    from shapely.geometry import Point, Polygon

    p = Point(float(xy[0]), float(xy[1]))
    obs = spec.obstacles
    near = [(abs(math.hypot(p.x - c.x, p.y - c.y) - c.radius), obstacle_label("circle", k))
            for k, c in enumerate(obs.circles)]  # fmt: skip
    near += [(Polygon(rectangle_vertices(r.x, r.y, r.length, r.width, r.angle_deg))
              .exterior.distance(p), obstacle_label("rectangle", k))
             for k, r in enumerate(obs.rectangles)]  # fmt: skip
    near += [(Polygon(sh.shell, sh.holes).boundary.distance(p), sh.label) for sh in shapes]
    return min(near)[1] if near else "an obstacle"


#: a map whose points (sensors, start, end) all lie within this share of the area's smaller
#: side of one another, and within `DEGREES_SPREAD` units, looks written in degrees
DEGREES_SHARE = 0.01
#: the most the points of a map written in degrees spread: a 100 km map spans ~0.9 degrees of
#: latitude, ~1.5 of longitude at 55 degrees north
DEGREES_SPREAD = 2.0


def _degrees_note(spec: MapFile) -> str | None:
    """A note when the map's positions look like longitude, latitude rather than metres: the
    sensors, start and end all lie within `DEGREES_SHARE` of the area's smaller side and
    `DEGREES_SPREAD` of one another (not all at one point), every x a longitude (<= 180) and
    every y a latitude (<= 90); said with the origin's lon, lat where the file gives one and
    the points lie within a degree of it. Not an error: a real map may hold its points near
    (5, 52) m. Cost: O(J)."""
    pts = np.array([(s.x, s.y) for s in spec.sensors] + [tuple(spec.start), tuple(spec.end)],
                   dtype=float)  # fmt: skip
    if not len(spec.sensors) or not np.all(np.isfinite(pts)):
        return None
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    spread = float(np.max(hi - lo))
    side = min(float(spec.area.width), float(spec.area.height))
    if not (0.0 < spread <= min(DEGREES_SHARE * side, DEGREES_SPREAD)):
        return None
    if hi[0] > 180.0 or hi[1] > 90.0:
        return None
    first = spec.sensors[0]
    at = f"sensor '{first.id}' at ({first.x:g}, {first.y:g})"
    o = spec.origin
    if o is not None and abs(first.x - o.lon) <= 1.0 and abs(first.y - o.lat) <= 1.0:
        at += f" is next to the origin's lon, lat ({o.lon:g}, {o.lat:g})"
    return (f"sensors: their x, y look like longitude, latitude ({at}; the sensors, start and "
            f"end all lie within {number_text(spread, 3)} m of one another in a "
            f"{number_text(spec.area.width)} m x {number_text(spec.area.height)} m area): x, y "
            "are metres east and north of the origin")


# ----------------------------------------------------------------------------- validation


def _loc(loc: tuple[Any, ...]) -> str:
    return textio.json_path(loc) or "(map)"


def _model_at(loc: tuple[Any, ...]) -> type[BaseModel] | None:
    """The pydantic model that owns the parent of `loc`, to suggest valid field names."""
    model: Any = MapFile
    for part in loc[:-1]:
        if isinstance(part, int):
            continue
        if model is None or not hasattr(model, "model_fields") or part not in model.model_fields:
            return None
        ann = model.model_fields[part].annotation
        model = _unwrap(ann)
    return model if isinstance(model, type) and issubclass(model, BaseModel) else None


def _unwrap(ann: Any) -> Any:
    for arg in getattr(ann, "__args__", ()) or ():
        u = _unwrap(arg)
        if isinstance(u, type) and issubclass(u, BaseModel):
            return u
    return ann


_RANGE_KINDS = frozenset({"greater_than", "greater_than_equal", "less_than", "less_than_equal"})
#: reasons for bounds on values inside lists and pairs (which have no field of their own)
_ITEM_REASONS = {
    "start": _WHY_COORD, "end": _WHY_COORD, "vertices": _WHY_COORD, "hover_points": _WHY_COORD,
    "hover_times": "a witness hover time lies in [0, 86400] s, as T_max",
}  # fmt: skip


def _range_reason(loc: tuple[Any, ...],
                  above: bool | None = None) -> tuple[str, str | None, bool]:  # fmt: skip
    """The documented reason for the bound that the value at `loc` broke (the side's own,
    `above` or below, where the field gives one), the field's valid interval ("[0.1,
    200]"; None for a value inside a list or pair, which has no field of its own), and
    whether the reason is that side's own (not the field's one reason for both ends)."""
    names = [i for i, part in enumerate(loc) if isinstance(part, str)]
    if not names:
        return "out of the documented range", None, False
    i = names[-1]
    if i < len(loc) - 1 or loc[i] in _ITEM_REASONS:
        return _ITEM_REASONS.get(str(loc[i]), "out of the documented range"), None, False
    model = _model_at(loc[: i + 1])
    info = model.model_fields.get(str(loc[i])) if model is not None else None
    extra = getattr(info, "json_schema_extra", None)
    if isinstance(extra, dict) and "x-range-reason" in extra:
        side = None if above is None else extra.get(
            "x-range-reason-above" if above else "x-range-reason-below")
        interval = extra.get("x-range")
        return (str(side or extra["x-range-reason"]),
                None if interval is None else str(interval), side is not None)
    if info is not None and info.description and "; " in info.description:
        return info.description.split("; ", 1)[1], None, False
    return "out of the documented range", None, False


#: pydantic's strict type errors -> what the field must be, in JSON's words
_TYPE_KINDS = {
    "float_type": "a JSON number",
    "int_type": "a JSON integer (no fraction, no quotes)",
    "int_from_float": "a JSON integer (no fraction, no quotes)",
    "string_type": "a JSON string",
    "bool_type": "true or false",
    "tuple_type": "a JSON array of two numbers [x, y] (metres)",
    "list_type": "a JSON array",
    # a nested section or item (`obstacles`, `uav.battery`, `sensors[0]`): pydantic names its
    # class ("a valid dictionary or instance of ObstaclesSpec"), the map file knows objects
    "model_type": "a JSON object",
    "dict_type": "a JSON object",
}


def _json_shown(v: Any) -> str:
    """A value as the map file spelled it, cut to 40 characters ("2000" is a string)."""
    import json

    try:
        text = json.dumps(v, ensure_ascii=True)
    except (TypeError, ValueError):
        text = repr(v)
    kind = {bool: "a boolean", str: "a string", type(None): "null", list: "an array",
            dict: "an object", int: "an integer", float: "a number"}.get(type(v), "a value")
    if len(text) > 40:  # a string cut keeps its closing quote: "abc..." not "abc...
        text = text[:36] + '..."' if isinstance(v, str) else text[:37] + "..."
    return f"{text} ({kind})"


#: what a list field holds, for its length messages ("must hold 1 to 100 depots")
_LIST_NOUNS = {"depots": "depots", "pads": "pads", "sensors": "sensors",
               "hover_points": "hover points", "hover_times": "hover times",
               "vertices": "vertices", "holes": "holes", "circles": "circles",
               "rectangles": "rectangles", "no_fly_zones": "no-fly zones"}  # fmt: skip


def _length_bounds(loc: tuple[Any, ...], ctx: Mapping[str, Any]) -> tuple[int | None, int | None]:
    """The (least, most) length the field at `loc` allows (its Field's min_length and
    max_length; None where it sets none), else the one bound pydantic's error gives (`ctx`):
    a message states the whole allowed range, whichever end was broken. O(depth of `loc`)."""
    import annotated_types

    lo, hi = ctx.get("min_length"), ctx.get("max_length")
    if not loc or not isinstance(loc[-1], str):
        return lo, hi
    model = _model_at(loc)
    info = model.model_fields.get(loc[-1]) if model is not None else None
    for meta in getattr(info, "metadata", ()) or ():
        if isinstance(meta, annotated_types.MinLen):
            lo = meta.min_length
        elif isinstance(meta, annotated_types.MaxLen):
            hi = meta.max_length
    return (lo or None), hi


def _length_problem(loc: tuple[Any, ...], where: str, e: Mapping[str, Any]) -> str:
    """A string or list of the wrong length (pydantic's string_too_short/_long, too_short/
    _long) in the house style: the field, what is allowed (both ends), what was given
    ("fleet.depots[1].name: must be 1 to 100 characters long, got "" (an empty string)").
    O(length of the value shown, cut to 40 characters)."""
    lo, hi = _length_bounds(loc, e.get("ctx") or {})
    got = e.get("input")
    text = isinstance(got, str) or e["type"].startswith("string")
    noun = "characters" if text else _LIST_NOUNS.get(
        next((str(p) for p in reversed(loc) if isinstance(p, str)), ""), "items")
    if lo is not None and hi is not None:
        allowed = f"{lo} to {hi} {noun}"
    elif hi is not None:
        allowed = f"at most {hi} {noun}"
    else:
        allowed = f"at least {lo} {noun}"
    if text:
        n = len(got) if isinstance(got, str) else (e.get("ctx") or {}).get("actual_length")
        shown = _json_shown(got).rsplit(" (", 1)[0] if isinstance(got, str) else "a string"
        size = "an empty string" if n == 0 else f"a string of {n} characters"
        return f"{where}: must be {allowed} long, got {shown} ({size})"
    n = len(got) if isinstance(got, (list, tuple)) else (e.get("ctx") or {}).get("actual_length")
    return f"{where}: must hold {allowed}, got {n}"


#: the characters `_PRINTABLE` refuses, by class: (first, last code point, the class in words)
_UNPRINTABLE_CLASSES = (
    (0x00, 0x1F, "a C0 control character"),
    (0x7F, 0x7F, "the control character DEL"),
    (0x80, 0x9F, "a C1 control character"),
    (0x2028, 0x2029, "a line or paragraph separator"),
    (0x202A, 0x202E, "a bidirectional embedding or override (it reorders what a terminal shows)"),
    (0x2066, 0x2069, "a bidirectional isolate (it reorders what a terminal shows)"),
)
_CHAR_WORDS = {"\n": "a newline", "\t": "a tab", "\r": "a carriage return"}


def _unprintable_problem(where: str, got: Any) -> str:
    """A name or id holding a character `_PRINTABLE` refuses, in the house style: the field,
    the first such character, its position and class, and what is allowed. O(len(got))."""
    import unicodedata

    allowed = ("must be printable text (no control characters, line or paragraph separators, "
               "or bidirectional controls: names are printed in one-line messages)")
    if not isinstance(got, str):
        return f"{where}: {allowed}"
    for k, ch in enumerate(got):
        code = ord(ch)
        cls = next((c for a, b, c in _UNPRINTABLE_CLASSES if a <= code <= b), None)
        if cls is None:
            continue
        name = unicodedata.name(ch, "")
        what = f"U+{code:04X} {name}" if name else f"U+{code:04X}"
        if ch in _CHAR_WORDS:
            what = f"{_CHAR_WORDS[ch]} ({what})"
        return f"{where}: {allowed}; character {k + 1} is {what}, {cls}"
    return f"{where}: {allowed}"


def _short_points(errors: list[Any]) -> set[tuple[Any, ...]]:
    """The fields given as an array of fewer than two numbers where a point [x, y] belongs:
    pydantic reports each missing item ("start[1]: required field is missing"); the house
    style names the field once, as for an array too long. A field whose missing items reach
    index 2 is a longer tuple, not a point. O(errors)."""
    missing: dict[tuple[Any, ...], set[int]] = {}
    for e in errors:
        loc = tuple(e["loc"])
        if e["type"] == "missing" and loc and isinstance(loc[-1], int):
            missing.setdefault(loc[:-1], set()).add(loc[-1])
    return {k for k, idx in missing.items() if idx and max(idx) < 2}


def _pydantic_problems(err: ValidationError) -> list[str]:
    lines = []
    errors = err.errors()
    points = _short_points(errors)
    for e in errors:
        loc = tuple(e["loc"])
        where = _loc(loc)
        kind = e["type"]
        if kind == "missing" and loc and isinstance(loc[-1], int) and loc[:-1] in points:
            line = (f"{_loc(loc[:-1])}: must be a JSON array of two numbers [x, y] (metres), "
                    f"got {_json_shown(e.get('input'))}")
            if line not in lines:
                lines.append(line)
            continue
        if kind == "extra_forbidden":
            model = _model_at(loc)
            hint = textio.did_you_mean(loc[-1], model.model_fields) if model is not None else ""
            lines.append(f"{where}: unknown field{hint}")
        elif kind == "missing":
            lines.append(f"{where}: required field is missing")
        elif kind in _TYPE_KINDS:
            lines.append(f"{where}: must be {_TYPE_KINDS[kind]}, got {_json_shown(e.get('input'))}")
        elif kind == "finite_number":
            lines.append(f"{where}: must be a finite number (got NaN or infinity)")
        elif kind == "too_short" and loc and loc[-1] == "sensors":
            lines.append(f"{where}: at least one sensor is required")
        elif kind == "too_short" and loc == ("fleet", "depots"):
            lines.append(f"{where}: give at least one depot, or leave the field out (one depot "
                         f"'{DEFAULT_DEPOT}' at the map's start)")  # fmt: skip
        elif kind == "too_long" and e.get("ctx", {}).get("max_length") == 2:  # a point
            lines.append(f"{where}: must be a JSON array of two numbers [x, y] (metres), got "
                         f"{_json_shown(e.get('input'))}")
        elif kind in ("string_too_short", "string_too_long", "too_short", "too_long"):
            lines.append(_length_problem(loc, where, e))
        elif kind == "string_pattern_mismatch":
            lines.append(_unprintable_problem(where, e.get("input")))
        elif kind in _RANGE_KINDS:
            got = e.get("input")
            shown = number_text(got) if isinstance(got, float) else repr(got)
            above = kind.startswith("less")
            reason, interval, own = _range_reason(loc, above)
            # the whole valid range, whichever end was broken, where the field has one
            msg = (f"must be in {interval}" if interval is not None
                   else e["msg"].replace("Input should be", "must be"))  # fmt: skip
            bound = (e.get("ctx") or {}).get("gt", (e.get("ctx") or {}).get("ge"))
            if not above and bound == 0 and not own:  # "> 0" needs no reason, and the
                lines.append(f"{where}: {msg} (got {shown})")  # field's one is the cap's
            else:
                lines.append(f"{where}: {msg} (got {shown}); {reason}")
        elif kind == "literal_error":  # "must be 'total' or 'makespan'", as the others read
            lines.append(f"{where}: {e['msg'].replace('Input should be', 'must be', 1)}, got "
                         f"{_json_shown(e.get('input'))}")
        else:
            lines.append(f"{where}: {e['msg']}")
    return lines


def _margin_problems(spec: MapFile) -> list[str]:
    """The required data the planner plans with, Q_j x (1 + safety.data_margin), kept within
    the limit of `radio.required_data` (the planning map is a map too): one problem naming the
    field the value came from (`radio.required_data` once for the sensors that take it)."""
    margin = float(spec.safety.data_margin)
    limit = float(MAP_DEFAULTS["radio.required_data"].bounds[1])
    if margin <= 0.0:
        return []
    given = [("radio.required_data", float(spec.radio.required_data))] if any(
        s.required_data is None for s in spec.sensors) else []
    given += [(f"sensors[{j}].required_data", float(s.required_data))
              for j, s in enumerate(spec.sensors) if s.required_data is not None]
    return [f"{name}: {number_text(q)} Mbit with safety.data_margin {margin:g} is "
            f"{number_text(q * (1.0 + margin))} Mbit to plan, above the limit {number_text(limit)} "
            "(lower one of them)" for name, q in given if q * (1.0 + margin) > limit]


def _semantic_problems(
    spec: MapFile, end_gap: float = 0.0,
) -> tuple[list[str], list[str], list[PolygonShape], Obstacles | None]:
    problems: list[str] = []
    notes: list[str] = []
    W, H = spec.area.width, spec.area.height

    def inside_area(x: float, y: float) -> bool:
        return 0.0 <= x <= W and 0.0 <= y <= H

    for name in ("start", "end"):
        x, y = getattr(spec, name)
        if not inside_area(x, y):
            problems.append(f"{name}: ({x:g}, {y:g}) is outside the area [0, {W:g}] x [0, {H:g}]")
    seen: set[str] = set()
    for j, s in enumerate(spec.sensors):
        if not inside_area(s.x, s.y):
            problems.append(
                f"sensors[{j}]: sensor '{s.id}' at ({s.x:g}, {s.y:g}) is outside the area "
                f"[0, {W:g}] x [0, {H:g}]"
            )
        if s.id in seen:
            problems.append(f"sensors[{j}].id: duplicate sensor id '{s.id}'")
        seen.add(s.id)
    problems += _margin_problems(spec)
    degrees = _degrees_note(spec)
    if degrees is not None:
        notes.append(degrees)
    obs = spec.obstacles
    for k, c in enumerate(obs.circles):
        if not inside_area(c.x, c.y):
            problems.append(
                f"obstacles.circles[{k}]: centre ({c.x:g}, {c.y:g}) is outside the area"
            )
    for k, r in enumerate(obs.rectangles):
        if not inside_area(r.x, r.y):
            problems.append(
                f"obstacles.rectangles[{k}]: centre ({r.x:g}, {r.y:g}) is outside the area"
            )
    shapes: list[PolygonShape] = []
    for kind, key, items in (("no_fly_zone", "no_fly_zones", obs.no_fly_zones),
                             ("polygon", "polygons", obs.polygons)):  # fmt: skip
        for k, z in enumerate(items):
            shape = _polygon_shape(kind, f"obstacles.{key}[{k}]", k, z, problems, notes)
            if shape is not None:
                shapes.append(shape)
    u = spec.uav
    if u.max_hover_points is not None and u.max_hover_points > MAX_HOVER_POINTS:
        problems.append(f"uav.max_hover_points: {u.max_hover_points} is too large "
                        f"(at most {MAX_HOVER_POINTS})")
    problems += _energy_problems(spec)
    depots = spec.fleet.depots if spec.fleet is not None and spec.fleet.depots else []
    names: set[str] = set()
    for k, dp in enumerate(depots):
        if not inside_area(dp.x, dp.y):
            problems.append(f"fleet.depots[{k}]: depot '{dp.name}' at ({dp.x:g}, {dp.y:g}) is "
                            f"outside the area [0, {W:g}] x [0, {H:g}]")  # fmt: skip
        if dp.name in names:
            problems.append(f"fleet.depots[{k}].name: duplicate depot name '{dp.name}'")
        names.add(dp.name)
        # a listed pad is a position the file gives, as the depot's is: outside the area it
        # is bad input whether or not a plan of this fleet uses it (one UAV uses none)
        for i, (x, y) in enumerate(dp.pads or ()):
            if not inside_area(x, y):
                problems.append(f"fleet.depots[{k}].pads[{i}]: the pad of depot '{dp.name}' at "
                                f"({x:g}, {y:g}) is outside the area [0, {W:g}] x [0, {H:g}]")
    if spec.witness is not None and len(spec.witness.hover_points) != len(spec.witness.hover_times):
        problems.append("witness: hover_points and hover_times differ in length")
    for k, (x, y) in enumerate(spec.witness.hover_points if spec.witness is not None else ()):
        if not inside_area(x, y):
            problems.append(f"witness.hover_points[{k}]: ({x:g}, {y:g}) is outside the area "
                            f"[0, {W:g}] x [0, {H:g}]: a plan through it is not feasible (C1)")
    if not problems:
        try:
            obstacles = _pack(spec, tuple(shapes))
        except ValueError as exc:  # a degenerate polygon the triangulation cannot cut
            problems.append(f"obstacles: {exc}")
            return problems, notes, shapes, None
        ends = np.array([spec.start, spec.end], dtype=float)
        inside = points_inside(ends, obstacles)
        gaps = _edge_distances(ends, spec, tuple(shapes)) if end_gap > 0 else np.full(2, np.inf)
        for name, flag, gap in zip(("start", "end"), inside, gaps, strict=True):
            x, y = getattr(spec, name)
            if flag:
                problems.append(f"{name}: ({x:g}, {y:g}) lies inside "
                                f"{_holding((x, y), spec, tuple(shapes))}")
            elif gap < end_gap:
                problems.append(
                    f"{name}: ({x:g}, {y:g}) lies {1000 * gap:.3g} mm from the edge of "
                    f"{_nearest_label((x, y), spec, tuple(shapes))}, closer than "
                    f"{100 * end_gap:g} cm: a mission file keeps positions on a 1e-7 degree "
                    "grid, which may move it up to 8 mm, into the obstacle"
                )
        if depots:
            where = np.array([(dp.x, dp.y) for dp in depots], dtype=float)
            inside = points_inside(where, obstacles)
            gaps = (_edge_distances(where, spec, tuple(shapes)) if end_gap > 0
                    else np.full(len(depots), np.inf))  # fmt: skip
            for k, (dp, flag, gap) in enumerate(zip(depots, inside, gaps, strict=True)):
                at = f"fleet.depots[{k}]: depot '{dp.name}' at ({dp.x:g}, {dp.y:g})"
                if flag:
                    problems.append(f"{at} lies inside "
                                    f"{_holding((dp.x, dp.y), spec, tuple(shapes))}: no sortie "
                                    "can take off or land there")  # fmt: skip
                elif gap < end_gap:
                    problems.append(f"{at} lies {1000 * gap:.3g} mm from the edge of "
                                    f"{_nearest_label((dp.x, dp.y), spec, tuple(shapes))}, "
                                    f"closer than {100 * end_gap:g} cm: a mission file keeps "
                                    "positions on a 1e-7 degree grid, which may move it up to "
                                    "8 mm, into the obstacle")  # fmt: skip
            listed = [(k, i, dp.name, xy) for k, dp in enumerate(depots)
                      for i, xy in enumerate(dp.pads or ())]  # fmt: skip
            if listed:
                inside = points_inside(np.array([xy for *_, xy in listed], dtype=float),
                                       obstacles)  # fmt: skip
                for (k, i, name, (x, y)), flag in zip(listed, inside, strict=True):
                    if flag:
                        problems.append(f"fleet.depots[{k}].pads[{i}]: the pad of depot "
                                        f"'{name}' at ({x:g}, {y:g}) lies inside "
                                        f"{_holding((x, y), spec, tuple(shapes))}: no vehicle "
                                        "can stand there")  # fmt: skip
        return problems, notes, shapes, obstacles
    return problems, notes, shapes, None


def _energy_problems(spec: MapFile) -> list[str]:
    """The battery's fields together: its energy given once (`uav.battery.energy_wh` or
    `uav.endurance_s`), never twice, and a `uav.battery` section that gives an energy."""
    u = spec.uav
    given = u.battery is not None and u.battery.energy_wh is not None
    if given and u.endurance_s is not None:
        return ["uav.endurance_s: the battery is given twice (uav.battery.energy_wh and "
                "uav.endurance_s): give one of them"]  # fmt: skip
    if u.battery is not None and not given and u.endurance_s is None:
        return ["uav.battery.energy_wh: required field is missing (the battery's energy in "
                "Wh; or give uav.endurance_s, the hover seconds on one battery)"]  # fmt: skip
    return []


def _polygon_shape(
    kind: str, where: str, index: int, z: NoFlyZone | PolygonObstacle,
    problems: list[str], notes: list[str],
) -> PolygonShape | None:
    """Clean, orient and check one polygon of the map file; None (and a problem) if unusable."""
    label = f"{where} '{z.name}'" if z.name else where
    try:
        shell, holes, said = clean_polygon([z.vertices, *z.holes])
    except ValueError as exc:
        # name the ring as the file does: ...vertices / ...holes[k]
        msg = str(exc)
        ring = re.match(r"(exterior ring|hole (\d+)) (.*)", msg)
        if ring:
            at = ".vertices" if ring.group(2) is None else f".holes[{ring.group(2)}]"
            problems.append(f"{label}{at}: {ring.group(3)}")
        else:
            problems.append(f"{label}: {msg}")
        return None
    notes += [f"{label}.vertices: {n}" if n.startswith("given clockwise") else f"{label}: {n}"
              for n in said]  # fmt: skip
    return PolygonShape(kind, index, z.name, shell, tuple(holes))


#: metres the start and end keep from every obstacle's edge: a mission file stores latitude
#: and longitude on a 1e-7 degree grid (MAVLink's int32 degrees x 1e7; 1e-7 degree is at most
#: 1.11 cm), so a stored point moves by up to half a step each way, < 7.9 mm in all
END_GAP = 0.01


def _edge_distances(
    points: np.ndarray, spec: MapFile, shapes: tuple[PolygonShape, ...]
) -> np.ndarray:
    """(N,) metres from each point to the nearest obstacle (0 inside one): circles exactly,
    rectangles, no-fly zones and polygon obstacles with shapely."""
    import shapely

    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    out = np.full(len(pts), np.inf)
    obs = spec.obstacles
    if obs.circles:
        c = np.array([(o.x, o.y, o.radius) for o in obs.circles], dtype=float)
        d = np.hypot(pts[:, None, 0] - c[None, :, 0], pts[:, None, 1] - c[None, :, 1])
        out = np.minimum(out, np.maximum(d - c[None, :, 2], 0.0).min(axis=1))
    polys = [shapely.Polygon(rectangle_vertices(r.x, r.y, r.length, r.width, r.angle_deg))
             for r in obs.rectangles]  # fmt: skip
    polys += [shapely.Polygon(sh.shell, list(sh.holes)) for sh in shapes]
    if polys:
        geom = shapely.STRtree(polys)
        spts = shapely.points(pts)
        nearest = geom.nearest(spts)
        out = np.minimum(out, shapely.distance(spts, np.asarray(polys, dtype=object)[nearest]))
    return out


def _pack(spec: MapFile, shapes: tuple[PolygonShape, ...]) -> Obstacles:
    """The kernel's obstacles: rectangles, then convex shapes, then the others as regions."""
    obs = spec.obstacles
    circles = [(c.x, c.y, c.radius) for c in obs.circles]
    rects = [rectangle_vertices(r.x, r.y, r.length, r.width, r.angle_deg) for r in obs.rectangles]
    flat = [sh.convex for sh in shapes]  # once per shape (`is_convex`, O(V))
    convex = [sh.shell for sh, c in zip(shapes, flat, strict=True) if c]
    regions = [(sh.shell, sh.holes) for sh, c in zip(shapes, flat, strict=True) if not c]
    return Obstacles.build(circles, rects + convex, regions)


def _size_problems(data: Mapping[str, Any]) -> list[str]:
    """Counts over the limits of `planner_core.textio.LIMITS`, checked on the raw data before
    validation (so a 100,000-sensor file costs no validation time); one line per problem."""
    try:
        caps = {k: textio.limit(k) for k in ("sensors", "obstacles", "zone_vertices", "vertices")}
    except textio.InputError as exc:
        return [f"(environment) {exc}"]

    def over(where: str, n: int, key: str, what: str) -> str:
        lim = textio.LIMITS[key]
        return (f"{where}: {n:,} {what}, more than the limit of {caps[key]:,} "
                f"({lim.why}; raise it with {lim.env})")  # fmt: skip

    problems = []
    sensors = data.get("sensors")
    if isinstance(sensors, list) and len(sensors) > caps["sensors"]:
        problems.append(over("sensors", len(sensors), "sensors", "sensors"))
    obs = data.get("obstacles")
    if isinstance(obs, Mapping):
        kinds = ("circles", "rectangles", "no_fly_zones", "polygons")
        n = sum(len(v) for k in kinds if isinstance(v := obs.get(k), list))
        if n > caps["obstacles"]:
            problems.append(over("obstacles", n, "obstacles", "obstacles"))
        total = 0
        for key in ("no_fly_zones", "polygons"):
            zones = obs.get(key)
            for k, z in enumerate(zones if isinstance(zones, list) and not problems else []):
                if not isinstance(z, Mapping):
                    continue
                holes = z.get("holes") if isinstance(z.get("holes"), list) else []
                for r, v in enumerate([z.get("vertices"), *holes]):
                    if isinstance(v, list):
                        total += max(len(v), 1)  # an empty ring still costs validation
                        if len(v) > caps["zone_vertices"]:
                            where = f"obstacles.{key}[{k}]." + (
                                "vertices" if r == 0 else f"holes[{r - 1}]")  # fmt: skip
                            problems.append(over(where, len(v), "zone_vertices", "vertices"))
                            break
        if not problems and total > caps["vertices"]:
            where = "obstacles.no_fly_zones" if not obs.get("polygons") else "obstacles"
            problems.append(over(where, total, "vertices", "vertices in all"))
    return problems


def _other_kind(data: dict[str, Any]) -> str | None:
    """What a JSON object given as a map is instead, when it is a file this project reads or
    writes elsewhere (its fields would otherwise show as "unknown field" one by one)."""
    if data.get("fileType") == "Plan" and "mission" in data:
        return ("this is a QGroundControl mission (.plan), not a map; a map is the JSON "
                "`lamde-mission plan` reads (docs/maps.md)")
    if data.get("type") in ("FeatureCollection", "Feature"):
        return ("this is GeoJSON, not a map; make a map from it with "
                "`lamde-mission map from-geojson FILE -o map.json`")
    if "sensors" in data:
        return None
    if "vehicles" in data:
        return "this is a sortie directory's fleet.json, not a map"
    if "hover_points" in data and "hover_times" in data:
        return ("this is a saved plan (`plan -o FILE.json`), not a map; give the map it was "
                "planned on")
    if isinstance(data.get("tasks"), dict):  # SUITE_best_known.json, SUITE_lower_bounds.json
        return ("this is a benchmark suite's best-known or lower-bounds file (per task), not a "
                "map; `bench` and `report` read it beside the suite's folder of maps")
    return None


def load_map(source: str | Path | Mapping[str, Any] | Map) -> Map:
    """Read and validate a map from a path, a JSON string's dict, or a Map.

    Args:
        source: a map file's path, its parsed JSON (a dict), or a Map (returned as it is).

    Returns:
        The validated Map.

    Raises:
        MapError: every problem found, one line each naming the field (the start or end
            closer than `END_GAP` to an obstacle's edge among them).
        TypeError: `source` is none of the above.
    """
    return _load_map(source, end_gap=END_GAP)


def _load_map(
    source: str | Path | Mapping[str, Any] | Map, *, end_gap: float, sized: bool = True
) -> Map:
    """`load_map` with the start's and end's least distance to an obstacle (0: the planning
    map, whose inflated obstacles may touch them); `sized` False skips the input limits (the
    planning map, made from a map that met them)."""
    if isinstance(source, Map):
        return source
    if isinstance(source, str | Path):
        path = Path(source)
        try:
            data = textio.read_json(path)
        except textio.InputError as exc:
            raise MapError([f"{path}: {exc}"]) from None
    elif isinstance(source, Mapping):
        data = dict(source)
    else:
        raise TypeError(f"load_map expects a path, a dict or a Map, got {type(source).__name__}")
    if not isinstance(data, dict):
        raise MapError(["(map): the top level must be a JSON object"])
    other = _other_kind(data)
    if other is not None:
        raise MapError([f"(map): {other}"])
    sizes = _size_problems(data) if sized else []
    if sizes:
        raise MapError(sizes)
    try:
        spec = MapFile.model_validate(data)
    except ValidationError as err:
        raise MapError(_pydantic_problems(err)) from None
    problems, notes, shapes, obstacles = _semantic_problems(spec, end_gap)
    if problems:
        raise MapError(problems, notes)
    nfz = tuple(sh.shell for sh in shapes if sh.kind == "no_fly_zone")
    m = Map(spec=spec, nfz_polygons=nfz, notes=tuple(notes), shapes=tuple(shapes))
    m.__dict__["obstacles"] = obstacles  # the cached_property, already built while checking
    return m

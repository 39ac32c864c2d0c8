"""Local map metres <-> WGS84 latitude/longitude: the sim's conversion (`sim.geo`), re-exported.

The mission vocabulary lives in the simulator (`sim`), which the mission writer depends on; this
module keeps the `lamde_mission.geo` import path.
"""

from sim.geo import MissingOriginError, enu_to_latlon, latlon_to_enu, origin_of

__all__ = ["MissingOriginError", "enu_to_latlon", "latlon_to_enu", "origin_of"]

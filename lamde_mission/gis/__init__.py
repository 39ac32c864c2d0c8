"""GIS in and out: GeoJSON layers and QGroundControl geofences to a map, a map to GeoJSON.

`read_layers` + `build_map` (import, `lamde-mission map from-geojson`), `map_to_geojson`
(export, `lamde-mission map to-geojson`). WGS84 only at this boundary; the map is local metres.
"""

from lamde_mission.gis.export import map_to_geojson
from lamde_mission.gis.importer import DEFAULT_MARGIN, GisError, GisLayers, build_map, read_layers

__all__ = ["DEFAULT_MARGIN", "GisError", "GisLayers", "build_map", "map_to_geojson", "read_layers"]

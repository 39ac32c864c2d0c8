"""The problem as the paper states it (Sec. 3): formulas, the map, obstacle geometry, routing on
the map, the vectorised `Problem` and its seeder. Nothing here searches; every search stage
(`planner_core.search`) and the pipeline (`planner_core.pipeline`) read it."""

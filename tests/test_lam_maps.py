"""The landscape-aware choice of LAMDE-S's training maps (planner_core.learning.lam.maps): Stage 1
on a pool of maps by hand, the ablations, refusals, features of real maps and the CLI's file
read back by the trainer."""

from __future__ import annotations

import json

import numpy as np
import pytest

from planner_core.learning.lam.maps import main, map_features, select_maps
from planner_core.learning.lam.probe import blas_single_thread
from planner_core.suite import generate_map, generated_maps, generated_spec
from tests.conftest import MAPS


def test_global_selection_takes_the_least_mean_distances_by_hand() -> None:
    pool = np.array([[0.0, 0.0], [10.0, 0.0], [1.0, 1.0], [0.0, 3.0], [5.0, 5.0]])
    targets = np.array([[0.0, 0.0], [2.0, 0.0]])
    idx, dist = select_maps(pool, targets, 2, standardise=False)
    want = [np.mean([np.hypot(*(p - t)) for t in targets]) for p in pool]
    np.testing.assert_allclose(dist, want)
    assert list(idx) == list(np.argsort(want, kind="stable")[:2]) == [0, 2]
    # local: each target's nearest in turn
    idx, _ = select_maps(pool, targets, 2, selection="local", standardise=False)
    assert sorted(idx) == [0, 2]


def test_random_selection_is_seeded_and_refusals_name_the_field() -> None:
    pool = np.arange(40.0).reshape(20, 2)
    a, _ = select_maps(pool, pool[:2], 5, selection="random", seed=3)
    b, _ = select_maps(pool, pool[:2], 5, selection="random", seed=3)
    assert list(a) == list(b) and len(set(a)) == 5
    with pytest.raises(ValueError, match="^k: 21 must be in 1..20"):
        select_maps(pool, pool[:2], 21)
    with pytest.raises(ValueError, match="^selection: 'near'"):
        select_maps(pool, pool[:2], 2, selection="near")


def test_features_of_maps_are_one_finite_row_each_and_seeded() -> None:
    with blas_single_thread():
        a = map_features([MAPS / "tiny.json", generated_maps(1, 5)[0][1]], seed=1)
        b = map_features([MAPS / "tiny.json"], seed=1)
    assert a.shape[0] == 2 and np.isfinite(a).all()
    np.testing.assert_array_equal(a[0], b[0])


def test_the_cli_writes_maps_the_trainer_regenerates(tmp_path) -> None:
    out = tmp_path / "picks.json"
    with blas_single_thread():
        assert main(["--pool", "6", "--pool-seed", "40", "--k", "2", "--targets",
                     str(MAPS / "tiny.json"), "-o", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["k"] == 2 and len(doc["maps"]) == 2
    pool = dict(generated_maps(6, 40))
    for m in doc["maps"]:
        assert generate_map(m["size"], m["density"], m["seed"]) == pool[m["name"]]
    assert generated_spec(3, 40) == (10000, 1, 43)
    assert doc["seed"] == 0
    for bad in (["--k", "7"], ["--k", "2", "--seed", "-1"], ["--k", "2", "--pool-seed", "-5"]):
        assert main(["--pool", "6", *bad, "-o", str(tmp_path / "x.json")]) == 2
    (tmp_path / "afile").write_text("")
    assert main(["--pool", "6", "--k", "2", "-o", str(tmp_path / "afile" / "x.json")]) == 2
    assert not (tmp_path / "x.json").exists()

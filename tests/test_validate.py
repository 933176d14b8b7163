"""analysis.validate: the pieces of the model-versus-simulation comparison that need no physics
(the end-to-end ``kruskal validate`` on a built model runs in test_builder.py)."""
from __future__ import annotations

import numpy as np
import pytest

from analysis.validate import _bootstrap_sd, _expected_plugin, model_grid, model_scene, reference_seed, validate_model
from kruskal_markov.model import ModelError, TransitionModel
from transition_builder.grid import ReportGrid
from transition_builder.scene import scene_from_options


def test_reference_seeds_are_fixed_and_distinct():
    seeds = [reference_seed(0, i) for i in range(50)]
    assert seeds == [reference_seed(0, i) for i in range(50)]           # a function of (seed, i) only
    assert len(set(seeds)) == 50 and all(0 <= s < 2 ** 31 - 1 for s in seeds)
    assert reference_seed(1, 0) != reference_seed(0, 0)


def test_expected_plugin_entropy_matches_its_closed_form():
    """Two equally likely cells and m = 2 draws: the plug-in entropy is 0 (same cell, probability
    1/2) or 1 bit, so its expectation is 0.5 bits; one draw or one cell: 0."""
    rng = np.random.default_rng(5)
    assert _expected_plugin(np.array([0.5, 0.5]), 1, rng) == 0.0
    assert _expected_plugin(np.array([0.0, 1.0, 0.0]), 40, rng) == 0.0
    assert _expected_plugin(np.array([0.5, 0.5]), 0, rng) == 0.0
    values = [_expected_plugin(np.array([0.5, 0.5]), 2, rng) for _ in range(40)]    # 40 x 200 draws
    assert abs(np.mean(values) - 0.5) < 4 * 0.5 / np.sqrt(40 * 200)
    # negative round-off is clipped and the distribution renormalised
    assert _expected_plugin(np.array([-1e-18, 2.0]), 10, rng) == 0.0


def test_bootstrap_sd():
    rng = np.random.default_rng(0)
    assert _bootstrap_sd(np.zeros(30, dtype=np.int64), 4, rng) == 0.0      # one cell: no spread
    assert _bootstrap_sd(np.array([2]), 4, rng) == 0.0                      # fewer than 2 labels
    # half the trials in each of two cells: the plug-in entropy's sd over resamples is about
    # the delta method's sqrt(var(log-ratio term) / m), near zero at p = 1/2; it is small and positive
    sd = _bootstrap_sd(np.repeat([0, 1], 50), 2, rng)
    assert 0.0 < sd < 0.05


def test_models_without_a_scene_or_grid_are_refused():
    plain = TransitionModel(["N"], [np.eye(2)])
    with pytest.raises(ModelError, match="no scene"):
        model_scene(plain)
    with pytest.raises(ModelError, match="no report grid"):
        model_grid(plain)
    scene = scene_from_options("rectangle:20x20")
    grid = ReportGrid(200.0, 200.0, 2, 2, 2, symmetry_order=4)
    built = TransitionModel(["N"], [np.eye(2)], metadata={"scene": scene.to_dict(), "grid": grid.to_dict()})
    assert model_scene(built).content_hash() == scene.content_hash()
    assert model_grid(built).to_dict() == grid.to_dict()
    # the partition must be on the report grid
    with pytest.raises(ModelError, match="partition"):
        validate_model(built, sequences=1, trials=2, length=1, bands=0, simulate=lambda *a: None)


@pytest.mark.parametrize("kw", [{"sequences": 0}, {"trials": 1}, {"length": 0}, {"bands": -1},
                                {"sequences": True}, {"trials": 2.5}])
def test_bad_counts_are_value_errors(kw):
    with pytest.raises(ValueError, match=next(iter(kw))):
        validate_model(TransitionModel(["N"], [np.eye(2)]), **kw)

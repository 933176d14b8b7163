"""analysis.friction_range: a plan replayed by direct simulation between the range's models.

The replay tests use a fake simulator whose outcome depends on the scene's friction (below 0.35 a
tilt carries every pose to one corner, above it nothing moves), so the share in the plan's cell
says which coefficient was simulated; the command-line test runs the real simulator on a few trials.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from analysis.cli import main
from analysis.friction_range import between_points, check_plan_between, parse_friction_range, plan_cell
from analysis.montecarlo import report_grid_for
from kruskal_markov.model import TransitionModel
from transition_builder.scene import scene_from_options

SHAPE = "polygon:0,0;40,0;0,25"
CORNER = (170.0, 170.0, 0.0)


class _SlideBelow:
    """Below mu = 0.35 every tilt leaves the part at ``CORNER``; above it the part does not move."""

    def __init__(self, scene):
        self.mu = float(scene.friction.mu)

    def tilt(self, poses, action_name):
        poses = np.asarray(poses, dtype=np.float64)
        rest = np.tile(CORNER, (len(poses), 1)) if self.mu < 0.35 else poses.copy()
        return rest, np.zeros(len(poses), dtype=np.int8)


@pytest.fixture(scope="module")
def scene():
    return scene_from_options(SHAPE)


def test_plan_cell_of_one_and_of_several_models():
    assert plan_cell(5) == 5 and plan_cell([5, 5, 5]) == 5
    assert plan_cell([5, 6]) is None and plan_cell(None) is None and plan_cell([5, None]) is None


def test_between_points_are_the_midpoints():
    assert between_points(parse_friction_range("0.2..0.4"), 5) == pytest.approx([0.225, 0.275, 0.325, 0.375])


def test_robust_plan_replayed_at_named_coefficients(scene):
    corner_cell = int(report_grid_for(scene).voxel_index(np.array([CORNER]))[0])
    rows = check_plan_between(scene, ["NE", "N"], [corner_cell] * 5, None, 0, 40, seed=11, workers=1,
                              coefficients=[0.225, 0.39], simulator_factory=_SlideBelow)
    low, high = rows
    assert [r["mu"] for r in rows] == [0.225, 0.39] and [r["seed"] for r in rows] == [11, 12]
    assert low["cell"] == corner_cell and low["in_cell"] == 40 and low["share_in_cell"] == 1.0
    assert low["share_in_cell_ci95"][0] > 0.9 and low["share_in_cell_ci95"][1] == 1.0
    # above 0.35 nothing moves: the uniform starts stay spread over the cells
    assert high["share_in_cell"] < 0.3 and high["share_in_modal_cell"] < 0.5
    assert high["share_in_cell_ci95"][0] <= high["share_in_cell"] <= high["share_in_cell_ci95"][1]
    # the models disagree on the cell: no promised cell, but the replay still says how gathered it is
    split = check_plan_between(scene, ["NE"], [corner_cell, corner_cell + 1], None, 0, 10, seed=1, workers=1,
                               coefficients=[0.3], simulator_factory=_SlideBelow)[0]
    assert split["share_in_cell"] is None and split["modal_cell"] == corner_cell
    assert split["share_in_modal_cell"] == 1.0


def _range_models(scene, tmp_path, rest_poses, matrix):
    """Stand-in for the range's builds: the report grid's start states plus ``rest_poses``; every
    tilt's matrix at coefficient ``mu`` is ``matrix(mu, n_start, n)``; models saved under ``tmp_path``."""
    grid = report_grid_for(scene)
    n_start = grid.n_voxels
    n = n_start + len(rest_poses)
    poses = np.full((n, 3), np.nan)
    poses[n_start:] = rest_poses
    partition = np.concatenate([np.arange(n_start), grid.voxel_index(poses[n_start:])])
    initial = np.concatenate([np.full(n_start, 1.0 / n_start), np.zeros(len(rest_poses))])

    def models(sc, frange, points, build_settings=None, **kw):
        out = []
        for spec in frange.points(points):
            P = matrix(float(spec), n_start, n)
            m = TransitionModel(scene.actions, [P] * len(scene.actions), initial=initial, partition=partition,
                                n_cells=grid.n_voxels, metadata={"build_settings": {"tol_mm": 0.0, "tol_deg": 0.0}},
                                extras={"state_poses": poses})
            path = str(tmp_path / f"m{spec}.npz")
            m.save(path)
            out.append((spec, m, path))
        return out

    return models


def _one_tilt_models(scene, tmp_path):
    """Under every tilt every state goes to one rest state."""
    def matrix(mu, n_start, n):
        P = np.zeros((n, n))
        P[:, n_start] = 1.0
        return P

    return _range_models(scene, tmp_path, [(100.0, 100.0, 0.0)], matrix)


def file_in_the_cache(monkeypatch, tmp_path, models, frange: str, points: int, shape: str = SHAPE,
                      resolution=(1.0, 1.0)) -> None:
    """Put stand-in models where a range command's builds look for them, so that the command runs
    whole (nothing in it replaced) and reads them as cached builds: a fresh model cache
    (``KRUSKAL_CACHE``) under ``tmp_path``, each model filed under the build key of what the command
    builds at that point (``shape`` at the point's friction, ``BuildSettings.compared`` at the range's
    resolution, ``--range-resolution``'s default 1,1). ``models(scene, frange, points)`` gives
    ``(spec, model, path)`` per point, as ``models_over_range`` does."""
    from dataclasses import replace

    from transition_builder.builder import BuildSettings, build_key
    from transition_builder.cache import cache_dir
    from transition_builder.friction import parse_friction

    monkeypatch.setenv("KRUSKAL_CACHE", str(tmp_path / "cache"))
    base = scene_from_options(shape)
    settings = BuildSettings.compared(tol_mm=resolution[0], tol_deg=resolution[1])
    for spec, model, _ in models(base, parse_friction_range(frange), points):
        key = build_key(replace(base, friction=parse_friction(spec)), settings)
        model.metadata["build_key"] = key
        model.save(f"{cache_dir()}/{key}.npz")


def test_plan_command_replays_its_robust_plan(monkeypatch, scene, tmp_path, capsys):
    file_in_the_cache(monkeypatch, tmp_path, _one_tilt_models(scene, tmp_path), "0.2..0.3", 2)
    assert main(["plan", "--friction", "0.2..0.3", "--shape", SHAPE, "--range-points", "2", "--target", "cell",
                 "--check-trials", "3", "--check-at", "0.27", "--seed", "9", "--workers", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["length"] == 1 and out["final_cell"] == [out["final_cell"][0]] * 2
    (row,) = out["friction_range"]["between_points"]
    assert row["mu"] == 0.27 and row["seed"] == 9 and row["trials"] == 3 and row["cell"] == out["final_cell"][0]
    assert 0 <= row["in_cell"] <= 3 and row["share_in_cell"] == row["in_cell"] / 3


@pytest.mark.parametrize("extra, words", [
    (["--check-at", "0.3"], "--check-at needs --check-trials"),
    (["--check-trials", "2", "--check-at", "0.3,abc"], "--check-at"),
    (["--check-trials", "2", "--check-at", "map:low:1"], "--check-at"),
    (["--check-trials", "-1"], "--check-trials"),
    (["--check-trials", "2", "--workers", "0"], "--workers"),
])
def test_bad_check_options_exit_2(extra, words, monkeypatch, scene, tmp_path, capsys):
    file_in_the_cache(monkeypatch, tmp_path, _one_tilt_models(scene, tmp_path), "0.2..0.3", 2)
    assert main(["plan", "--friction", "0.2..0.3", "--shape", SHAPE, "--range-points", "2", *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err


def test_rank_builds_the_fit_grid_models_with_the_fit_grid_settings():
    """``rank --resolution 1,1 --start-samples 2000`` asks for the very models of a friction range's
    default grid (one build key), so a fitted interval's models serve the ranking too."""
    from analysis.cli import build_parser
    from analysis.commands.rank import scenes_and_settings
    from transition_builder.builder import BuildSettings, build_key
    from transition_builder.friction import parse_friction

    args = build_parser().parse_args(["rank", "--shapes", "allen-key", SHAPE, "--friction", "0.2", "--resolution",
                                      "1,1", "--start-samples", "2000", "--recenter-rounds", "1"])
    scenes, settings = scenes_and_settings(args)
    fit_grid = BuildSettings.compared()
    for spec, sc in scenes.items():
        from dataclasses import replace

        ours = replace(scene_from_options(spec), friction=parse_friction("0.2"))
        assert build_key(sc, settings) == build_key(ours, fit_grid)
    assert build_key(scenes["allen-key"], settings) != build_key(scenes[SHAPE], settings)


def _two_way_models(scene, tmp_path):
    """Every tilt sends every state to rest state A with probability 1 - mu and to B with mu (the
    answers move with mu)."""
    def matrix(mu, n_start, n):
        P = np.zeros((n, n))
        P[:, n_start], P[:, n_start + 1] = 1 - mu, mu
        return P

    return _range_models(scene, tmp_path, [(50.0, 50.0, 0.0), (150.0, 150.0, 0.0)], matrix)


def test_ensemble_over_a_range_gives_each_points_answers(monkeypatch, scene, tmp_path, capsys):
    file_in_the_cache(monkeypatch, tmp_path, _two_way_models(scene, tmp_path), "0.0..0.4", 3)
    assert main(["ensemble", "--friction", "0.0..0.4", "--shape", SHAPE, "--count", "10", "--length", "4",
                 "--range-points", "3", "--draws", "0", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    r = out["friction_range"]
    at = r["at_points"]
    assert list(at) == ["0", "0.2", "0.4"]
    # mu = 0 converges on the first tilt, mu > 0 never does: which end is which is in at_points
    assert at["0"]["converged"] == 10 and at["0.2"]["converged"] == at["0.4"]["converged"] == 0
    assert r["range"]["converged"] == [0, 10] and out["converged"] == at["0.2"]["converged"]


def test_convergence_over_a_range_gives_each_points_expected_length(monkeypatch, scene, tmp_path, capsys):
    """``at_points`` keeps nested answers: each point's ``expected_length`` (it dropped them, so a
    range's ends could not be told apart for ``convergence``)."""
    file_in_the_cache(monkeypatch, tmp_path, _two_way_models(scene, tmp_path), "0.0..0.4", 3)
    assert main(["convergence", "--friction", "0.0..0.4", "--shape", SHAPE, "--range-points", "3", "--draws", "0",
                 "--runs", "50", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    at = out["friction_range"]["at_points"]
    assert list(at) == ["0", "0.2", "0.4"]
    # mu = 0 synchronizes on the first tilt, mu > 0 never does (two rest states stay reachable)
    assert at["0"]["expected_length"]["exact"] == 1.0 and at["0"]["infinite"] is False
    assert at["0.2"]["infinite"] is True and at["0.4"]["infinite"] is True and out["infinite"] is True
    assert "expected_length" not in at["0.2"]                   # all null there: nothing to keep

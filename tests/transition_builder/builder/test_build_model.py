"""Tests for the transition-model builder: known transitions, accounting, symmetry against direct
simulation, noise determinism, checkpoint resume after SIGKILL, executors, cache, CLI."""
from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import tests
from kruskal_markov.model import TransitionModel
from transition_builder.builder import STATE_REST, STATE_START, BuildSettings, build_key, build_model
from transition_builder.executors import SerialExecutor, make_executor
from transition_builder.scene import scene_from_options
from transition_builder.sim import TraySimulator

ROOT = str(tests.ROOT)
#: the executor of the builds here: two kept worker processes (a model is the same on every executor,
#: which test_local_pool_and_dask_give_identical_models checks against a serial build)
BUILDS = make_executor(2)
ACTIONS = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")
# action -> (x, y) components of its downhill direction
COMPONENTS = {"N": (0, 1), "NE": (1, 1), "E": (1, 0), "SE": (1, -1), "S": (0, -1), "SW": (-1, -1),
              "W": (-1, 0), "NW": (-1, 1)}


def _square_scene():
    # a 30 mm square in a 90 mm tray: small, so few rest states; mu 0.1 so edges come to rest flush
    return scene_from_options("rectangle:30x30", friction_spec=0.1, tray_mm=(90.0, 90.0))


@pytest.fixture(scope="module")
def square_build():
    settings = BuildSettings(start_samples=150, max_states=1200, seed=3)
    return build_model(_square_scene(), settings, executor=BUILDS)


def test_corner_states_have_the_known_transitions(square_build):
    """A square resting in a corner goes to the corner its tilt points at (sliding along a wall when
    the tilt is straight): the corner automaton is known exactly. Where it comes to rest is judged
    within 1 mm and 1 degree (hitting the far wall, the square can bounce up to ~0.6 mm off the wall
    it slid along: the engine's restitution, a real effect of the simulated physics)."""
    m = square_build.model
    poses = m.extras["state_poses"]
    kind = m.extras["state_kind"]

    def corner_pos(cx, cy):
        return (15.0 if cx < 0 else 75.0), (15.0 if cy < 0 else 75.0)

    def aligned(th, tol_deg):
        return np.abs(np.mod(th + 0.25, math.pi / 2) - 0.25) < math.radians(tol_deg)

    checked = 0
    for cx in (-1, 1):
        for cy in (-1, 1):
            x, y = corner_pos(cx, cy)
            d = np.hypot(poses[:, 0] - x, poses[:, 1] - y)
            states = np.flatnonzero((kind == STATE_REST) & (d < 0.2) & aligned(poses[:, 2], 0.5))
            assert states.size, f"no explored corner state at ({x}, {y})"
            for a, name in enumerate(ACTIONS):
                ax, ay = COMPONENTS[name]
                ex, ey = corner_pos(ax if ax else cx, ay if ay else cy)
                for s in states:
                    row = m.matrices[a].getrow(s)
                    assert row.nnz == 1 and row.data[0] == 1.0          # deterministic physics
                    t = row.indices[0]
                    assert abs(poses[t, 0] - ex) < 1.0 and abs(poses[t, 1] - ey) < 1.0, \
                        f"corner ({x}, {y}) under {name} went to {poses[t]}, expected near ({ex}, {ey})"
                    assert aligned(poses[t, 2], 1.0)
                    checked += 1
    assert checked >= 32


def test_every_sample_is_accounted_for(square_build):
    m = square_build.model
    samples, faults = m.extras["samples"], m.extras["faults"]
    kind = m.extras["state_kind"]
    for a in range(m.n_actions):
        counts = np.asarray(m.extras[f"counts_{a}"], dtype=np.int64)
        P = m.matrices[a]
        per_row = np.add.reduceat(np.append(counts, 0), P.indptr[:-1])[:m.n_states] * (np.diff(P.indptr) > 0)
        np.testing.assert_array_equal(per_row + faults[a], samples[a])
        # every explored rest state was sampled exactly `samples_per_row` times per action
        assert np.all(samples[a][kind == STATE_REST] == square_build.stats["samples_per_row"])
        # rows are the normalised counts
        rows = np.repeat(np.arange(m.n_states), np.diff(P.indptr))
        counted = samples[a][rows] - faults[a][rows] > 0
        np.testing.assert_allclose(P.data[counted], counts[counted] / (samples[a] - faults[a])[rows][counted])
    # every start sample is in a start row: start samples x actions in all
    start = kind == STATE_START
    assert samples[:, start].sum() == square_build.stats["start_samples"] * m.n_actions
    st = square_build.stats
    assert st["sampled_transitions"] == samples.sum()
    assert st["faults"] == faults.sum()
    assert st["states"] == m.n_states


def test_initial_distribution_is_the_start_grid(square_build):
    m = square_build.model
    kind = m.extras["state_kind"]
    assert np.all(m.initial[kind != STATE_START] == 0)
    assert abs(m.initial.sum() - 1) < 1e-12
    assert len(set(m.partition[kind == STATE_START].tolist())) == int((kind == STATE_START).sum())


def test_initial_weights_are_proportional_to_start_samples(square_build):
    """A start state's initial probability is its share of the start samples (the uniform start
    poses, under every symmetry rotation, that fall in its cell), not 1 / (number of start states).
    Every (rotated) start sample is tilted once under each representative action, so the sample
    counts of the start rows summed over the actions (book-kept by the row assembly, apart from
    the initial distribution) are proportional to them."""
    m = square_build.model
    start = m.extras["state_kind"] == STATE_START
    counts = m.extras["samples"][:, start].sum(axis=0).astype(np.float64)
    np.testing.assert_allclose(m.initial[start], counts / counts.sum(), rtol=1e-12, atol=0)
    assert counts.min() < counts.max(), "start counts all equal: the check could not tell weights from uniform"


def test_derived_rows_agree_with_direct_simulation(square_build):
    """Rows of rotated copies come from rotating the representative's landings; simulate those
    states directly and check that their landings are where the derived rows say."""
    m = square_build.model
    poses = m.extras["state_poses"]
    kind = m.extras["state_kind"]
    rest = np.flatnonzero(kind == STATE_REST)
    n_start = int((kind == STATE_START).sum())
    rotated = rest[(rest - n_start) % 4 != 0]            # rotation j != 0: derived, never simulated
    rng = np.random.default_rng(1)
    pick = rng.choice(rotated, size=min(60, len(rotated)), replace=False)
    acts = rng.integers(0, 8, len(pick))
    tol = np.array([0.5, 0.5, math.radians(0.5)])
    grid_cells = m.partition
    agree_cell = close = 0
    with TraySimulator(_square_scene()) as sim:
        for s, a in zip(pick, acts):
            land, status = sim.tilt(poses[s][None], ACTIONS[a])
            assert status[0] == 0
            t = m.matrices[a].getrow(s).indices[0]
            d = land[0] - poses[t]
            d[2] = (d[2] + math.pi / 4) % (math.pi / 2) - math.pi / 4   # square: theta modulo 90 deg
            close += np.sqrt(((d / tol) ** 2).sum()) <= 1.05
            from analysis.validate import model_grid
            agree_cell += model_grid(m).voxel_index(land)[0] == grid_cells[t]
    assert agree_cell == len(pick)
    assert close >= 0.95 * len(pick)


def test_zero_noise_is_bit_identical_and_noise_is_seeded():
    scene = _square_scene()
    base = dict(start_samples=60, max_states=160, seed=5)
    none = build_model(scene, BuildSettings(noise="none", **base), executor=BUILDS).model
    zero = build_model(scene, BuildSettings(noise="pose:0,0", **base), executor=BUILDS).model
    assert none.same_arrays(zero)
    s = BuildSettings(noise="pose:0.5,0.5", samples=3, **base)
    a = build_model(scene, s, executor=BUILDS).model
    b = build_model(scene, s, executor=BUILDS).model
    assert a.same_arrays(b)
    assert not a.same_arrays(none)
    # noisy rows are estimated from several samples, so some are genuinely stochastic
    assert any(np.any(mat.data < 1) for mat in a.matrices)
    assert build_key(scene, s) != build_key(scene, BuildSettings(noise="none", **base))


def test_local_pool_and_dask_give_identical_models():
    """Serial, a 2-process pool and a Dask cluster: the same model, state poses included. A full
    build of the square (about 130 tasks) is big enough that a simulator carrying state from one
    task to the next gave other landings (up to 1e-3 rad) depending on which worker ran what."""
    distributed = pytest.importorskip("distributed")
    scene = _square_scene()
    s = BuildSettings(start_samples=120, seed=0, tol_mm=0.5, tol_deg=0.5)
    serial = build_model(scene, s, executor=SerialExecutor()).model
    pool = make_executor(2)
    local = build_model(scene, s, executor=pool).model
    assert serial.same_arrays(local)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cl:
        from transition_builder.executors import DaskExecutor
        with DaskExecutor(cl.scheduler_address) as ex:
            dask = build_model(scene, s, executor=ex).model
    assert serial.same_arrays(dask)


_RESUME_SCRIPT = textwrap.dedent("""
    import sys
    from transition_builder.builder import BuildSettings, build_model
    from transition_builder.executors import SerialExecutor
    from transition_builder.scene import scene_from_options
    scene = scene_from_options("rectangle:30x30", friction_spec=0.1, tray_mm=(90.0, 90.0))
    r = build_model(scene, BuildSettings(start_samples=100, seed=4, tol_mm=0.5, tol_deg=0.5), executor=SerialExecutor(),
                    checkpoint=sys.argv[1], checkpoint_interval_s=0.0, batch_tilts=160)
    r.model.save(sys.argv[2])
    print("resumed" if r.stats["resumed"] else "fresh")
""")


def test_resume_after_sigkill(tmp_path):
    ckpt, out = str(tmp_path / "b.ckpt.npz"), str(tmp_path / "m.npz")
    script = tmp_path / "run.py"
    script.write_text(_RESUME_SCRIPT)
    env = dict(os.environ, PYTHONPATH=ROOT)
    proc = subprocess.Popen([sys.executable, str(script), ckpt, out], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL)
    # wait until at least one exploration checkpoint has been written after the start phase
    deadline = time.time() + 120
    seen = 0
    while time.time() < deadline and proc.poll() is None:
        if os.path.exists(ckpt):
            try:
                with np.load(ckpt) as z:
                    if int(z["explored"].sum()) > 0:
                        seen = int(z["explored"].sum())
                        break
            except Exception:
                pass
        time.sleep(0.05)
    assert proc.poll() is None, "the build finished before it could be killed"
    assert seen > 0
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert not os.path.exists(out)
    res = subprocess.run([sys.executable, str(script), ckpt, out], env=env, capture_output=True, text=True,
                         timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.strip() == "resumed"
    assert not os.path.exists(ckpt)                       # removed once the model is written
    fresh = build_model(scene_from_options("rectangle:30x30", friction_spec=0.1, tray_mm=(90.0, 90.0)),
                        BuildSettings(start_samples=100, seed=4, tol_mm=0.5, tol_deg=0.5), executor=BUILDS,
                        batch_tilts=160).model          # the same task grouping as the killed build
    assert TransitionModel.load(out).same_arrays(fresh)


def test_cache_reuse_and_corrupt_file(tmp_path, recwarn):
    from transition_builder.cache import cached_build

    scene = _square_scene()
    s = BuildSettings(start_samples=40, max_states=100, seed=9)
    r1, p1, c1 = cached_build(scene, s, directory=str(tmp_path), executor=BUILDS)
    r2, p2, c2 = cached_build(scene, s, directory=str(tmp_path), executor=BUILDS)
    assert (c1, c2) == (False, True) and p1 == p2
    assert r1.model.same_arrays(r2.model)
    # another scene never reuses it
    other = scene.with_settings(solver_iterations=90)
    _, p3, c3 = cached_build(other, s, directory=str(tmp_path), executor=BUILDS)
    assert not c3 and p3 != p1
    with open(p1, "r+b") as fh:                          # corrupt the cached file
        fh.seek(100)
        fh.write(b"\0" * 200)
    r4, _, c4 = cached_build(scene, s, directory=str(tmp_path), executor=BUILDS)
    assert not c4
    assert any("rebuilding" in str(w.message) for w in recwarn.list)
    assert r1.model.same_arrays(r4.model)


def test_build_and_validate_end_to_end(tmp_path):
    """`kruskal build` then `kruskal validate` on a small scene, through the command line."""
    env = dict(os.environ, KRUSKAL_CACHE=str(tmp_path / "cache"))
    model = str(tmp_path / "sq.npz")
    exe = [sys.executable, "-m", "analysis"]
    b = subprocess.run(exe + ["build", "--shape", "rectangle:30x30", "--friction", "0.1", "--start-samples", "120",
                              "--max-states", "100000", "--out", model, "--workers", "2", "--json",
                              "--scene", _write_scene(tmp_path)],
                       env=env, capture_output=True, text=True, timeout=900, cwd=ROOT)
    assert b.returncode == 0, b.stderr[-2000:]
    res = json.loads(b.stdout)
    for key in ("model", "states", "voxels_total", "tilts_simulated", "fault_rate", "cached", "seconds"):
        assert key in res
    assert res["cached"] is False and res["unexplored_states"] == 0 and res["states"] > 0
    assert res["tilts_saved_by_symmetry"] == 3 * res["sampled_transitions"] // 4
    again = subprocess.run(exe + ["build", "--shape", "rectangle:30x30", "--friction", "0.1", "--start-samples",
                                  "120", "--max-states", "100000", "--out", model, "--json",
                                  "--scene", _write_scene(tmp_path)],
                           env=env, capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert again.returncode == 0 and json.loads(again.stdout)["cached"] is True
    v = subprocess.run(exe + ["validate", "--model", model, "--sequences", "2", "--trials", "60", "--length", "5",
                              "--seed", "1", "--bands", "5", "--workers", "2", "--json"],
                       env=env, capture_output=True, text=True, timeout=900, cwd=ROOT)
    assert v.returncode == 0, v.stderr[-2000:]
    out = json.loads(v.stdout)
    for key in ("mean_abs_error_bits", "max_abs_error_bits", "share_steps_above_0_25", "per_sequence",
                "final_tv_distance", "reference_noise_bits", "band_coverage", "model_seconds",
                "simulation_seconds", "seconds"):
        assert key in out
    assert len(out["per_sequence"]) == 2 and len(out["per_sequence"][0]["reference"]) == 6
    # a closed model of this small deterministic scene predicts its own physics closely
    assert out["mean_abs_error_bits"] < 0.3
    assert 0 <= out["final_tv_distance"] <= 1


def _write_scene(tmp_path) -> str:
    path = tmp_path / "scene.json"
    if not path.exists():
        _square_scene().save(str(path))
    return str(path)


@pytest.mark.parametrize("argv, needle", [
    (["build", "--resolution", "abc"], "resolution"),
    (["build", "--noise", "pose:1"], "noise"),
    (["build", "--shape", "nonsense"], "shape"),
    (["build", "--max-states", "0"], "max_states"),
    (["validate", "--model", "/nonexistent.npz"], "not found"),
])
def test_bad_input_is_one_line_exit_2(argv, needle):
    res = subprocess.run([sys.executable, "-m", "analysis", *argv], capture_output=True, text=True, timeout=120,
                         cwd=ROOT)
    assert res.returncode == 2
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and needle in lines[0].lower(), res.stderr


def test_refinement_splits_diverging_representatives():
    """Refinement tilts the farthest member of each representative and splits where a landing falls
    in another report cell; the split-off states are real rest poses whose rows are their own tilts."""
    scene = _square_scene()
    # probes off: refinement alone, so every rest row is one landing
    base = build_model(scene, BuildSettings(start_samples=150, seed=3, recenter_rounds=0, tol_mm=0.5, tol_deg=0.5,
                                            probes=0), executor=BUILDS)
    ref = build_model(scene, BuildSettings(start_samples=150, seed=3, refine_rounds=2, recenter_rounds=0, probes=0,
                                    tol_mm=0.5, tol_deg=0.5),
                      executor=BUILDS)
    st = ref.stats
    assert st["refinement_rounds"] == 2 and st["refinement_tilts"] > 0
    assert st["representatives_split"] > 0
    assert st["representatives"] >= base.stats["representatives"] + st["representatives_split"]
    assert st["unexplored_states"] == 0
    m = ref.model
    kind = m.extras["state_kind"]
    for a in range(m.n_actions):                                  # still every sample accounted for
        counts = np.asarray(m.extras[f"counts_{a}"], dtype=np.int64)
        rows = np.repeat(np.arange(m.n_states), np.diff(m.matrices[a].indptr))
        per_row = np.bincount(rows, weights=counts, minlength=m.n_states)
        np.testing.assert_array_equal(per_row + m.extras["faults"][a], m.extras["samples"][a])
        assert np.all(m.extras["samples"][a][kind == STATE_REST] == 1)
    # refinement costs tilts of its own
    assert ref.stats["tilts_simulated"] > base.stats["tilts_simulated"]


def test_recentring_moves_representatives_onto_resting_points():
    """Recentring moves a representative onto the densest point of its members and tilts it again;
    every landing still has a representative and every sample is accounted for."""
    scene = _square_scene()
    r = build_model(scene, BuildSettings(start_samples=150, seed=3, recenter_rounds=2, probes=0),
                    executor=BUILDS)
    st = r.stats
    assert st["recentring_rounds"] >= 1 and st["representatives_moved"] > 0
    assert st["unexplored_states"] == 0
    m = r.model
    kind = m.extras["state_kind"]
    for a in range(m.n_actions):
        counts = np.asarray(m.extras[f"counts_{a}"], dtype=np.int64)
        rows = np.repeat(np.arange(m.n_states), np.diff(m.matrices[a].indptr))
        per_row = np.bincount(rows, weights=counts, minlength=m.n_states)
        np.testing.assert_array_equal(per_row + m.extras["faults"][a], m.extras["samples"][a])
        assert np.all(m.extras["samples"][a][kind == STATE_REST] == 1)
    # a moved representative is a real rest pose: tilting it reproduces its row's target cell
    poses = m.extras["state_poses"]
    rest = np.flatnonzero(kind == STATE_REST)[::4][:20]
    from analysis.validate import model_grid
    grid = model_grid(m)
    with TraySimulator(scene) as sim:
        land, status = sim.tilt(poses[rest], "NE")
    assert np.all(status == 0)
    targets = [m.matrices[1].getrow(s).indices[0] for s in rest]
    assert np.array_equal(grid.voxel_index(land), m.partition[targets])


def test_weighted_exploration_borrows_rows_of_nearby_explored_states():
    """Weighted exploration (noisy scenes) expands only states that carry probability; an unexplored
    state takes the row of the nearest explored state in its report cell and contact group, and
    that is said in the model (``borrowed_from``) and in the statistics -- the samples still add up."""
    from transition_builder.builder import STATE_UNEXPLORED

    scene = _square_scene()
    s = BuildSettings(noise="pose:0.5,0.5", samples=3, start_samples=60, explore_weight=0.05, seed=5, max_samples=0)
    r = build_model(scene, s, executor=BUILDS)
    m, st = r.model, r.stats
    kind = m.extras["state_kind"]
    assert st["unexplored_states"] > 0 and st["rows_borrowed"] > 0
    lender = m.extras["borrowed_from"]
    borrowers = np.flatnonzero(lender >= 0)
    assert len(borrowers) == st["rows_borrowed"]
    assert np.all(kind[borrowers] == STATE_UNEXPLORED) and np.all(kind[lender[borrowers]] == STATE_REST)
    # a lender lies in the borrower's report cell within 8 tolerance units, except the few
    # borrowers with nothing there, which are counted as borrowing from afar
    poses = m.extras["state_poses"]
    d = np.abs(poses[borrowers, :2] - poses[lender[borrowers], :2]).max(axis=1)
    near = (m.partition[borrowers] == m.partition[lender[borrowers]]) & (d <= 8 * s.tol_mm + 1e-9)
    assert np.sum(~near) <= st["rows_borrowed_from_afar"] < len(borrowers)
    for a, P in enumerate(m.matrices):
        for b in borrowers[:50]:
            row, src = P.getrow(b), P.getrow(lender[b])
            assert np.array_equal(row.indices, src.indices) and np.allclose(row.data, src.data)
        assert np.all(m.extras["samples"][a][borrowers] == 0)
        counts = np.asarray(m.extras[f"counts_{a}"], dtype=np.int64)
        rows = np.repeat(np.arange(m.n_states), np.diff(P.indptr))
        per_row = np.bincount(rows, weights=counts, minlength=m.n_states)
        np.testing.assert_array_equal(per_row + m.extras["faults"][a], m.extras["samples"][a])
        np.testing.assert_allclose(np.asarray(P.sum(axis=1)).ravel(), 1.0)
    # no unexplored state is left without a row (one would hold its mass for ever)
    assert not np.any((kind == STATE_UNEXPLORED) & (lender < 0))
    # the states the first tilt reaches are all explored
    first = np.unique(np.concatenate([P[:int(np.sum(kind == STATE_START))].indices for P in m.matrices]))
    assert np.all(kind[first] == STATE_REST)


def test_snap_compensation_subtracts_the_snapping_offset_from_the_noise():
    """With ``snap_compensation`` a representative is perturbed by sqrt(sigma^2 - spread^2) per
    coordinate, where spread is the root-mean-square offset of the snapped landings from their
    representatives (between 0 and the tolerance)."""
    from dataclasses import replace

    from transition_builder.builder import compensated_noise
    from transition_builder.noise import NoiseSpec

    c = compensated_noise(NoiseSpec("pose", 0.5, 0.5), 0.3, 0.6)
    assert math.isclose(c.sigma_mm, 0.4) and c.sigma_deg == 0.0
    assert compensated_noise(NoiseSpec("none"), 0.3, 0.3).is_zero
    scene = _square_scene()
    s = BuildSettings(noise="pose:0.5,0.5", samples=3, start_samples=60, explore_weight=0.05, seed=5,
                      snap_compensation=True, max_samples=0)
    assert build_key(scene, s) != build_key(scene, replace(s, snap_compensation=False))
    a = build_model(scene, s, executor=BUILDS)
    b = build_model(scene, s, executor=BUILDS)
    assert a.model.same_arrays(b.model)
    plain = build_model(scene, replace(s, snap_compensation=False), executor=BUILDS)
    assert not a.model.same_arrays(plain.model)
    st = a.stats
    assert 0 < st["snap_spread_mm"] < s.tol_mm and 0 < st["snap_spread_deg"] < s.tol_deg
    added = compensated_noise(NoiseSpec("pose", 0.5, 0.5), st["snap_spread_mm"], st["snap_spread_deg"])
    assert st["representative_noise"] == str(added)
    assert plain.stats["representative_noise"] == "pose:0.5,0.5"


def test_confirm_samples_tops_up_only_the_rows_whose_samples_disagree():
    """Agreement-staged top-up: a heavy row first gets ``confirm_samples`` samples per action; only
    a (row, action) whose samples disagree (a fault, or landings in two report cells) gets the rest.
    So a row with the full K samples spans two cells or holds a fault (its first samples are among
    them), and a row stopped at ``confirm_samples`` lies in one cell without faults."""
    from dataclasses import replace

    scene = _square_scene()
    s = BuildSettings(noise="pose:0.5,0.5", samples=6, samples_first=2, confirm_samples=3,
                      start_samples=60, explore_weight=0.05, seed=5)
    assert build_key(scene, s) != build_key(scene, replace(s, confirm_samples=0))
    with pytest.raises(ValueError, match="between samples_first"):
        BuildSettings(noise="pose:0.5,0.5", samples=6, confirm_samples=6, explore_weight=0.05)
    with pytest.raises(ValueError, match="weighted exploration"):
        BuildSettings(noise="pose:0.5,0.5", samples=6, confirm_samples=3, explore_weight=0.0)
    r = build_model(scene, s, executor=BUILDS)
    assert r.model.same_arrays(build_model(scene, s, executor=BUILDS).model)
    m = r.model
    assert r.stats["confirm_samples"] == 3
    rest = m.extras["state_kind"] == STATE_REST
    seen = set()
    for a, P in enumerate(m.matrices):
        n = m.extras["samples"][a]
        seen |= set(np.unique(n[rest]).tolist())
        assert set(np.unique(n[rest]).tolist()) <= {2, 3, 6}
        counts = np.asarray(m.extras[f"counts_{a}"], dtype=np.int64)
        rows = np.repeat(np.arange(m.n_states), np.diff(P.indptr))
        np.testing.assert_array_equal(np.bincount(rows, weights=counts, minlength=m.n_states)
                                      + m.extras["faults"][a], n)
        for k, agree in ((3, True), (6, False)):
            for i in np.flatnonzero(rest & (n == k)):
                cells = np.unique(m.partition[P.indices[P.indptr[i]:P.indptr[i + 1]]])
                assert (len(cells) == 1 and m.extras["faults"][a][i] == 0) == agree
    assert {3, 6} <= seen          # (every row of this small scene is heavy)
    plain = build_model(scene, replace(s, confirm_samples=0), executor=BUILDS)
    assert r.stats["tilts_simulated"] < plain.stats["tilts_simulated"]


def test_flush_side_is_on_without_noise_and_keys_stay_apart():
    """The flush side is the deterministic default and off with noise (so the noisy default's cache
    key is the one it had before the option existed); switching it changes a deterministic key."""
    scene = _square_scene()
    assert BuildSettings().flush_side is True
    assert BuildSettings(noise="pose:0.5,0.5").flush_side is False
    assert build_key(scene, BuildSettings()) != build_key(scene, BuildSettings(flush_side=False))
    assert build_key(scene, BuildSettings(noise="pose:0.5,0.5")) == \
        build_key(scene, BuildSettings(noise="pose:0.5,0.5", flush_side=False))


def test_member_probes_are_on_by_default_only_where_they_were_chosen():
    """Probes with a distance are the deterministic default at the default tolerance (and finer);
    off with noise, weighted exploration or a coarser tolerance (where they hurt), unless asked."""
    assert (BuildSettings().probes, BuildSettings().probe_distance) == (4, 4.0)
    assert BuildSettings(tol_mm=0.1, tol_deg=0.1).probes == 4
    assert BuildSettings(noise="pose:0.5,0.5").probes == 0 and BuildSettings(explore_weight=0.01).probes == 0
    assert BuildSettings(tol_mm=0.5, tol_deg=0.5).probes == 0
    assert BuildSettings(tol_mm=0.25, tol_deg=1.0).probes == 0
    assert (BuildSettings(tol_mm=0.5, tol_deg=0.5, probes=4).probes,
            BuildSettings(tol_mm=0.5, tol_deg=0.5, probes=4).probe_distance) == (4, 4.0)
    assert BuildSettings(probes=0).probe_distance == 0.0
    scene = _square_scene()
    assert build_key(scene, BuildSettings()) != build_key(scene, BuildSettings(probes=0))
    assert build_key(scene, BuildSettings(tol_mm=1.0, tol_deg=1.0)) == \
        build_key(scene, BuildSettings(tol_mm=1.0, tol_deg=1.0, probes=0))


def _flush_mismatch(scene, model) -> tuple[float, int]:
    """Re-tilt the rotation-0 rest states (state ``n_start + o * G + j`` is rotation ``j`` of orbit
    ``o``) under N and NE; the share of landings whose contact
    signature with the flush side differs from that of the state their row points to, and how many
    of those target states lie flush."""
    from analysis.validate import model_grid
    from transition_builder.snapping import wall_contacts

    kind, poses = model.extras["state_kind"], model.extras["state_poses"]
    n_start = int(np.sum(kind == STATE_START))
    order = int(model.metadata["symmetry_order"])
    rest = np.flatnonzero((kind == STATE_REST) & ((np.arange(model.n_states) - n_start) % order == 0))

    def signature(p):
        return wall_contacts(scene.shape, p, scene.tray_x_mm, scene.tray_y_mm, 0.05, flush_side=True)

    grid = model_grid(model)
    bad, total, flush = 0, 0, 0
    for a, name in enumerate(("N", "NE")):
        with TraySimulator(scene) as sim:
            land, status = sim.tilt(poses[rest], name)
        assert np.all(status == 0)
        targets = np.array([model.matrices[a].getrow(s).indices[0] for s in rest])
        np.testing.assert_array_equal(grid.voxel_index(land), model.partition[targets])
        bad += int(np.sum(signature(land) != signature(poses[targets])))
        total += len(rest)
        flush += int(np.sum(signature(poses[targets]) >> 4 > 0))
    return bad / total, flush


def test_flush_side_build_never_snaps_across_the_two_ends_of_a_flush_edge(square_build):
    """With the flush side (the default), a landing snaps only onto a representative with the same
    report cell and contact signature including the flush bits: re-tilting a state's pose lands in
    a pose with the signature of the state its row points to. Not always exactly: a trial carries a
    little Bullet state from the one before it in its task (up to 1e-3 rad, docs/simulator.md), and
    a pose within 1e-3 rad of flush can then rest on the other end; on the square 0.8% of the
    re-tilts did, where a build without the flush side mismatches 38% (the slow test below)."""
    share, flush = _flush_mismatch(_square_scene(), square_build.model)
    assert flush > 20, "too few representatives lie flush against a wall: the test would check little"
    assert share <= 0.03


@pytest.mark.slow
def test_without_the_flush_side_landings_snap_across_the_two_ends():
    """The check above can fail: without the flush side, many landings snap onto a representative
    resting on the other end of a flush edge."""
    scene = _square_scene()
    r = build_model(scene, BuildSettings(start_samples=150, max_states=1200, seed=3, flush_side=False),
                    executor=BUILDS)
    share, _ = _flush_mismatch(scene, r.model)
    assert share > 0.1


def test_max_samples_gives_heavy_rows_samples_in_proportion_to_their_weight():
    """With ``max_samples`` every explored row ends with at least ``K * w / heavy_weight`` samples
    (rounded up to a multiple of K, at most ``max_samples``), where ``w`` is its weight on the
    weighing sequences through the finished model (the build stops only when no row wants more);
    the samples still add up, and the option leaves other keys alone when off."""
    from dataclasses import replace

    from transition_builder.builder import (
        _WEIGHT_LENGTH,
        _WEIGHT_SEQUENCES,
        _WEIGHT_STREAM,
        _WEIGHT_THRESHOLD,
        _proportional_samples,
    )

    scene = _square_scene()
    s = BuildSettings(noise="pose:0.5,0.5", samples=3, start_samples=60, explore_weight=0.05, seed=5,
                      max_samples=12, heavy_weight=0.1)
    plain = replace(s, max_samples=0)
    assert build_key(scene, plain) == build_key(scene, replace(plain, heavy_weight=0.3)) != build_key(scene, s)
    for bad in ({"max_samples": 3}, {"max_samples": 12, "explore_weight": 0.0}, {"max_samples": 12, "heavy_weight": 0.0}):
        with pytest.raises(ValueError):
            BuildSettings(**{**s.to_dict(), **bad})
    with pytest.raises(ValueError, match="process noise"):
        BuildSettings(max_samples=12)
    # on by default for weighted noisy builds only
    assert BuildSettings(noise="pose:0.5,0.5").max_samples == 128 and BuildSettings().max_samples == 0
    assert BuildSettings(noise="pose:0.5,0.5", explore_weight=0.0).max_samples == 0
    assert BuildSettings(noise="pose:0.5,0.5", samples=8, confirm_samples=4).max_samples == 0
    r = build_model(scene, s, executor=BUILDS)
    m = r.model
    assert m.same_arrays(build_model(scene, s, executor=BUILDS).model)
    # the weights, as the builder computes them, on the finished model
    rng = np.random.default_rng([s.seed, _WEIGHT_STREAM])
    seqs = rng.integers(0, m.n_actions, size=(_WEIGHT_SEQUENCES, _WEIGHT_LENGTH))
    T = [P.T.tocsr() for P in m.matrices]
    dist = np.repeat(m.initial[:, None], _WEIGHT_SEQUENCES, axis=1)
    w = dist.max(axis=1)
    for t in range(_WEIGHT_LENGTH):
        for a in range(m.n_actions):
            cols = np.flatnonzero(seqs[:, t] == a)
            dist[:, cols] = T[a] @ dist[:, cols]
        np.maximum(w, dist.max(axis=1), out=w)
    kind = m.extras["state_kind"]
    rest = np.flatnonzero(kind == STATE_REST)
    G = r.stats["symmetry_order"]
    orbit_w = np.repeat(w[rest].reshape(-1, G).max(axis=1), G)
    want = _proportional_samples(orbit_w, 3, 0.1, 12)
    heavy = orbit_w >= _WEIGHT_THRESHOLD        # the rows topped up from samples_first (2) to K (3)
    for a, P in enumerate(m.matrices):
        n = m.extras["samples"][a]
        assert np.all(n[rest][heavy] >= want[heavy]) and np.all(n[rest] <= 12)
        assert np.all((n[rest] % 3 == 0) | (n[rest] == 2))
        counts = np.asarray(m.extras[f"counts_{a}"], dtype=np.int64)
        rows = np.repeat(np.arange(m.n_states), np.diff(P.indptr))
        np.testing.assert_array_equal(np.bincount(rows, weights=counts, minlength=m.n_states)
                                      + m.extras["faults"][a], n)
    assert np.any(want > 3) and r.stats["rows_sampled_by_weight"] > 0
    assert r.stats["weighted_sample_tilts"] == sum(int(np.sum(np.maximum(m.extras["samples"][a][rest] - 3, 0)))
                                                   for a in range(m.n_actions)) // G
    assert np.array_equal(_proportional_samples([0.0, 0.05, 0.1, 0.11, 0.25, 0.9], 3, 0.1, 12), [3, 3, 3, 6, 9, 12])


def test_checkpoint_keeps_the_samples_added_by_weight(tmp_path):
    """The extra samples of ``max_samples`` are part of the checkpoint (a resumed build continues
    with exactly the rows it had), and a checkpoint of another build is not loaded."""
    from transition_builder.builder import _Exploration

    ex = _Exploration(n_actions=2, samples=3)
    ex.add_orbits(np.array([[10.0, 20.0, 0.1], [30.0, 40.0, 0.2]]))
    ex.start_poses, ex.start_land = np.zeros((4, 3)), np.zeros((1, 4, 3))
    ex.start_status = np.zeros((1, 4), dtype=np.int8)
    ex.more_src = np.array([[1, 0, 3], [1, 1, 3]])
    ex.more_land = np.array([[31.0, 41.0, 0.3], [np.nan, np.nan, np.nan]])
    ex.more_status = np.array([0, 3], dtype=np.int8)
    path = str(tmp_path / "c.npz")
    ex.save(path, "key-a")
    back = _Exploration.load(path, "key-a", 2, 3)
    assert back is not None and _Exploration.load(path, "key-b", 2, 3) is None
    assert np.array_equal(back.more_src, ex.more_src) and np.array_equal(back.more_status, ex.more_status)
    np.testing.assert_array_equal(back.more_land, ex.more_land)
    assert back.more_count.tolist() == [0, 1] and back.more_count.dtype == np.int64


def _probe_scene():
    # an acute triangle in a small tray with a 1 mm tolerance: its landings are sensitive to the
    # start pose inside a representative's tolerance often enough to exercise the member probes
    return scene_from_options("triangle:1", friction_spec=0.3, tray_mm=(100.0, 100.0))


_PROBE_SETTINGS = BuildSettings(start_samples=100, seed=2, tol_mm=1.0, tol_deg=1.0, recenter_rounds=1, probes=2,
                                probe_weight=0.3, probe_distance=0.0)


@pytest.fixture(scope="module")
def probed_build():
    """The probe scene built with member probes (cell-sensitive rows only), shared by two tests."""
    return build_model(_probe_scene(), _PROBE_SETTINGS, executor=BUILDS)


def test_member_probes_give_sensitive_rows_their_members_landings(probed_build):
    """With ``probes``, a heavy representative's row under an action takes its members' landings
    where one of them lands in another report cell (or faults where the representative does not);
    every other row keeps the representative's single landing. Samples still add up, a sensitive
    row spans more than one report cell, and the option leaves the cache key of a build without it
    alone."""
    from dataclasses import replace

    scene, s = _probe_scene(), _PROBE_SETTINGS
    st, m = probed_build.stats, probed_build.model
    assert st["probes"] == 2 and st["probe_tilts"] > 0
    assert st["rows_probed_sensitive"] > 0, "the scene should have rows that are sensitive inside the tolerance"
    kind = m.extras["state_kind"]
    samples, faults = m.extras["samples"], m.extras["faults"]
    rest = kind == STATE_REST
    spread_rows = 0
    for a in range(m.n_actions):
        P = m.matrices[a]
        counts = np.asarray(m.extras[f"counts_{a}"], dtype=np.int64)
        rows = np.repeat(np.arange(m.n_states), np.diff(P.indptr))
        per_row = np.bincount(rows, weights=counts, minlength=m.n_states)
        np.testing.assert_array_equal(per_row + faults[a], samples[a])
        probed = rest & (samples[a] > 1)
        # a probed row: the representative and 1..2 members; the others: one sample, one target
        assert np.all(samples[a][probed] <= 3)
        single = rest & (samples[a] == 1)
        assert np.all(np.diff(P.indptr)[single] <= 1)
        for i in np.flatnonzero(probed):
            cells = m.partition[P.indices[P.indptr[i]:P.indptr[i + 1]]]
            # kept only because a member's landing differs in cell (or in faulting) from the rep's
            assert len(np.unique(cells)) > 1 or 0 < faults[a][i] < samples[a][i]
            spread_rows += 1
    # symmetry: every sensitive (orbit, action) pair gives one row per rotation
    assert spread_rows == st["rows_probed_sensitive"] * st["symmetry_order"]
    assert build_key(scene, replace(s, probes=0)) == build_key(scene, replace(s, probes=0, probe_weight=0.5))
    assert build_key(scene, replace(s, probes=0)) != build_key(scene, s)
    for bad in ({"probes": -1}, {"probes": 2, "noise": "pose:0.5,0.5"}, {"probes": 2, "probe_weight": 0.0}):
        with pytest.raises(ValueError):
            BuildSettings(**{**s.to_dict(), **bad})


def test_probe_distance_also_spreads_rows_whose_members_scatter_inside_a_cell(probed_build):
    """``probe_distance`` adds the rows where a member lands in the representative's report cell
    but farther than that many tolerance balls from its landing: the same members are tilted, so
    the probed rows are a strict superset of the cell-sensitive ones (the states before probing
    keep their indices); at 0 the option is left out of the cache key."""
    from dataclasses import replace

    from transition_builder.builder import settings_design

    scene, s = _probe_scene(), _PROBE_SETTINGS
    cell_only = probed_build
    far = build_model(scene, replace(s, probe_distance=2.0), executor=BUILDS)
    assert far.stats["rows_probed_sensitive"] > cell_only.stats["rows_probed_sensitive"] > 0
    for a in range(cell_only.model.n_actions):
        rows_cell = np.flatnonzero(cell_only.model.extras["samples"][a] > 1)
        rows_far = np.flatnonzero(far.model.extras["samples"][a] > 1)
        assert set(rows_cell.tolist()) <= set(rows_far.tolist())
    assert "probe_distance" not in settings_design(s.to_dict())
    assert settings_design(replace(s, probe_distance=2.0).to_dict())["probe_distance"] == 2.0
    assert build_key(scene, s) != build_key(scene, replace(s, probe_distance=2.0))
    for bad in (-1.0, float("nan"), float("inf"), True):
        with pytest.raises(ValueError):
            replace(s, probe_distance=bad)


def test_row_weights_walk_each_sequence_with_scipys_arithmetic():
    """The builder's row weights (largest probability a state holds along random sequences) from
    the compiled per-sequence walk: bit for bit what sparse products over blocks of columns give
    (the formulation it replaced), and close to a dense reference."""
    import scipy.sparse as sp

    from transition_builder._propagation import max_probability_along

    rng = np.random.default_rng(3)
    n, n_act = 60, 3
    mats = []
    for _ in range(n_act):
        dense = rng.random((n, n)) * (rng.random((n, n)) < 0.08)
        dense[np.arange(n), rng.integers(0, n, n)] += 0.5
        mats.append(sp.csr_matrix(dense / dense.sum(axis=1, keepdims=True)))
    init = np.zeros(n)
    init[:5] = 0.2
    seqs = rng.integers(0, n_act, size=(25, 9))
    got = max_probability_along(mats, init, seqs)
    transposed = [P.T.tocsr() for P in mats]
    dist = np.asfortranarray(np.repeat(init[:, None], len(seqs), axis=1))
    want = dist.max(axis=1)
    dense_want = init.copy()
    for t in range(seqs.shape[1]):
        for a in range(n_act):
            cols = np.flatnonzero(seqs[:, t] == a)
            if len(cols):
                dist[:, cols] = transposed[a] @ dist[:, cols]
        np.maximum(want, dist.max(axis=1), out=want)
    for s in seqs:
        p = init.copy()
        for a in s:
            p = p @ mats[a].toarray()
            dense_want = np.maximum(dense_want, p)
    assert np.array_equal(got, want)
    np.testing.assert_allclose(got, dense_want, rtol=1e-12, atol=1e-15)
    assert (got[5:] > 0).sum() > 20 and got[5:].max() > 0.1    # the mass spreads and gathers: not a trivial case
    with pytest.raises(ValueError, match="action indices"):
        max_probability_along(mats, init, seqs + n_act)

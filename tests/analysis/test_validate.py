"""analysis.validate: the pieces of the model-versus-simulation comparison that need no physics
(the end-to-end ``kruskal validate`` on a built model runs in test_build_model.py)."""
from __future__ import annotations

import numpy as np
import pytest

from analysis.validate import (
    model_grid,
    model_scene,
    reference_seed,
    validate_model,
    wilson_interval,
)
from kruskal_markov.model import ModelError, TransitionModel
from transition_builder.grid import ReportGrid
from transition_builder.scene import scene_from_options


def test_reference_seeds_are_fixed_and_distinct():
    seeds = [reference_seed(0, i) for i in range(50)]
    assert seeds == [reference_seed(0, i) for i in range(50)]           # a function of (seed, i) only
    assert len(set(seeds)) == 50 and all(0 <= s < 2 ** 31 - 1 for s in seeds)
    assert reference_seed(1, 0) != reference_seed(0, 0)


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


# --- every figure of `kruskal validate` by value, on a case checked by hand ------------------------

def _built_point_model():
    """8 report cells = 8 states, every tilt sends every state to cell 0 (sampled once per row)."""
    import scipy.sparse as sp

    scene = scene_from_options("rectangle:20x20")
    grid = ReportGrid(200.0, 200.0, 2, 2, 2, symmetry_order=4)
    n = grid.n_voxels
    mats = [sp.csr_matrix((np.ones(n), (np.arange(n), np.zeros(n, dtype=int))), shape=(n, n))
            for _ in scene.actions]
    extras = {f"counts_{a}": np.ones(n, dtype=np.int64) for a in range(len(scene.actions))}
    md = {"kind": "kruskal.built_model", "stats": {"states": n}, "scene": scene.to_dict(), "grid": grid.to_dict(),
          "noise": "none"}
    return TransitionModel(list(scene.actions), mats, initial=np.full(n, 1.0 / n), partition=np.arange(n),
                           n_cells=n, metadata=md, extras=extras), grid


def _fake_reference(grid, cells_per_step, m):
    """A direct-simulation result whose trials sit in the given cells at each step (no faults)."""
    from types import SimpleNamespace

    from kruskal_markov.entropy import histogram_entropy_bits

    labels = np.array([np.resize(c, m) for c in cells_per_step])          # (steps, m)
    poses = grid.centres(labels.T.ravel()).reshape(m, len(cells_per_step), 3)
    h = np.array([histogram_entropy_bits(np.bincount(lab, minlength=grid.n_voxels)) for lab in labels])
    return SimpleNamespace(poses=poses, status=np.zeros((m, len(cells_per_step)), dtype=np.int8),
                           surviving=np.full(len(cells_per_step), m), entropy_bits=h, faults={})


def test_validate_figures_by_value_on_a_hand_checked_case():
    """Model: all mass in cell 0 from tilt 1 on (0 bits exactly, whatever M). Reference: all trials in
    cell 0, except at tilts 3 and 7 of sequence 0 (half in cell 0, half in cell 1: 1 bit) and at the
    last tilt of sequence 1 (half in cell 0, a quarter each in cells 2 and 3: 1.5 bits). By hand, over
    2 x 10 tilts: errors 1, 1 and 1.5 bits, so mean 3.5 / 20 = 0.175, max 1.5, median 0, share above
    0.25 = 3 / 20; the band (a one-point posterior, width 1.645 x the bootstrap sd, which is zero on
    one cell) misses exactly those 3 steps: coverage 17 / 20 = 0.85, Wilson 95% 0.640-0.948; a point-mass
    model cannot be widened, so those steps need an infinite delta and the 90% quantile (the 19th
    smallest of 20) is infinite: None; final total variation: sequence 0 ends in cell 0 (0), sequence
    1 at 0.5 (half its trials outside cell 0): mean 0.25."""
    model, grid = _built_point_model()
    length, m = 10, 40
    two = [0, 1]
    spread3 = [0, 0, 2, 3]

    def fake(scene, seq, trials, seed, noise):
        i = fake.calls
        fake.calls += 1
        steps = [list(range(8))] + [[0]] * length                  # step 0: one trial per cell, uniform
        if i == 0:
            steps[3] = two
            steps[7] = two
        else:
            steps[length] = spread3
        return _fake_reference(grid, steps, trials)
    fake.calls = 0
    out = validate_model(model, sequences=2, trials=m, seed=4, length=length, bands=5, simulate=fake)
    assert out["mean_abs_error_bits"] == pytest.approx(3.5 / 20)
    assert out["max_abs_error_bits"] == pytest.approx(1.5)
    assert out["median_abs_error_bits"] == 0.0
    assert out["share_steps_above_0_25"] == pytest.approx(3 / 20)
    assert out["mean_abs_error_bits_exact_curve"] == pytest.approx(3.5 / 20)
    assert out["final_tv_distance"] == pytest.approx(0.25)
    assert out["reference_noise_bits"] >= 0 and out["reference_noise_bits_max"] < 0.2
    assert out["band_steps"] == 20
    assert out["band_coverage"] == pytest.approx(0.85)
    assert out["band_coverage_dirichlet"] == pytest.approx(0.85)
    assert out["band_coverage_ci95"] == pytest.approx([0.6396, 0.9476], abs=1e-3)
    assert out["structural_delta_q90"] is None
    assert out["structural_source"] == "default" and out["structural_delta"] == 0.105
    s0, s1 = out["per_sequence"]
    assert s0["mean_abs_error_bits"] == pytest.approx(0.2) and s1["mean_abs_error_bits"] == pytest.approx(0.15)
    assert s0["band_coverage"] == pytest.approx(0.8) and s1["band_coverage"] == pytest.approx(0.9)
    assert s0["final_tv_distance"] == 0.0 and s1["final_tv_distance"] == pytest.approx(0.5)
    assert s0["structural_needed"][1:] == [0.0, 0.0, None, 0.0, 0.0, 0.0, None, 0.0, 0.0, 0.0]
    # the model's step 0 through the plug-in estimator: 40 draws from 8 equal cells; by linearity the
    # expectation is 8 E[-(n/40) log2(n/40)] with n ~ Binomial(40, 1/8) (Monte Carlo of 200 draws)
    from scipy.stats import binom

    k = np.arange(1, m + 1)
    exact0 = 8 * float(np.sum(binom.pmf(k, m, 1 / 8) * -(k / m) * np.log2(k / m)))
    assert s0["model"][0] == pytest.approx(exact0, abs=0.02) and exact0 < 2.9
    assert s0["model"][1:] == [0.0] * length and s0["model_exact"] == pytest.approx([3.0] + [0.0] * length)
    assert out["band_verdict"] == "consistent"


def test_coverage_verdict_fails_a_band_that_is_too_wide_as_well_as_too_narrow():
    from analysis.validate import coverage_verdict

    assert coverage_verdict(90, 100) == "consistent"
    assert coverage_verdict(100, 100) == "too wide"         # Wilson 96.3-100% lies above 85-95%
    assert coverage_verdict(60, 100) == "too narrow"
    assert coverage_verdict(20, 20) == "consistent"         # 20 steps: 83.9-100%, cannot tell
    assert coverage_verdict(120, 120) == "too wide"


def test_spread_and_every_other_key_by_value_on_the_hand_checked_case():
    """The same case with ``--spread``: at half the time step sequence 0's trials stay in cell 0 at tilts
    3 and 7 (0 bits where the default run had 1), sequence 1 repeats itself. By hand: the simulator's
    spread is 1 bit at 2 of sequence 0's 10 tilts (mean 0.2, max 1) and 0 on sequence 1 (overall
    mean 2 / 20 = 0.1, max 1); the model (0 bits from tilt 1) against the half-step run: 0 on sequence
    0, 1.5 bits at sequence 1's last tilt (mean 0.15, max 1.5). The band: a one-point posterior (each
    row sampled once, to one cell) on a converged model, so the centre is the matched curve, the
    width 1.645 x the reference's bootstrap sd and the structural term adds nothing."""
    from analysis.sequences import random_sequences_for

    model, grid = _built_point_model()
    length, m, seed = 10, 40, 4
    default_dt = model_scene(model).settings.time_step_s
    calls = []

    def fake(scene, seq, trials, sd, noise):
        half = scene.settings.time_step_s < default_dt
        assert scene.settings.time_step_s == (default_dt / 2 if half else default_dt)      # half: 1/480 s
        calls.append((list(seq), sd, half, noise))
        i = sum(1 for c in calls if c[2] == half) - 1
        steps = [list(range(8))] + [[0]] * length
        if i == 0 and not half:
            steps[3] = steps[7] = [0, 1]
        elif i == 1:
            steps[length] = [0, 0, 2, 3]
        return _fake_reference(grid, steps, trials)

    out = validate_model(model, sequences=2, trials=m, seed=seed, length=length, bands=5, simulate=fake, spread=True)
    seqs = random_sequences_for(model.n_actions, 2, length, seed)
    assert [(c[0], c[1], c[2], c[3]) for c in calls] == [
        (list(seqs[0]), reference_seed(seed, 0), False, "none"), (list(seqs[0]), reference_seed(seed, 0), True, "none"),
        (list(seqs[1]), reference_seed(seed, 1), False, "none"), (list(seqs[1]), reference_seed(seed, 1), True, "none")]
    assert out["simulation_spread_bits"] == pytest.approx({"mean": 0.1, "max": 1.0})
    s0, s1 = out["per_sequence"]
    assert s0["simulation_spread_bits"] == pytest.approx({"mean": 0.2, "max": 1.0})
    assert s1["simulation_spread_bits"] == {"mean": 0.0, "max": 0.0}
    assert s0["model_vs_half_time_step"] == {"mean": 0.0, "max": 0.0}
    assert s1["model_vs_half_time_step"] == pytest.approx({"mean": 0.15, "max": 1.5})
    assert s0["half_time_step"] == pytest.approx([3.0] + [0.0] * length)
    assert s1["half_time_step"] == pytest.approx([3.0] + [0.0] * (length - 1) + [1.5])
    for i, s in enumerate((s0, s1)):
        assert s["sequence"] == [model.actions[a] for a in seqs[i]] and s["reference_seed"] == reference_seed(seed, i)
        assert s["max_abs_error_bits"] == (1.0 if i == 0 else 1.5) and s["faults"] == {}
        ref = [3.0] + [0.0] * length
        if i == 0:
            ref[3] = ref[7] = 1.0
        else:
            ref[length] = 1.5
        assert s["reference"] == pytest.approx(ref)
        sd = np.asarray(s["reference_sd"])
        assert len(sd) == length + 1 and sd[0] > 0
        assert s["reference_noise_bits"] == pytest.approx(sd[1:].mean())
        w = 1.6448536269514722 * sd
        assert s["band_width"] == pytest.approx(w.tolist())
        assert s["band_centre"] == pytest.approx(s["model"])
        assert s["band_lo"][1:] == pytest.approx((-w[1:]).tolist()) and s["band_hi"][1:] == pytest.approx(w[1:].tolist())
        assert s["band_coverage_dirichlet"] == s["band_coverage"]
    # sd > 0 only where the reference has two or more cells: step 0, tilts 3 and 7 of sequence 0, the last of 1
    assert [k for k, x in enumerate(s0["reference_sd"]) if x > 0] == [0, 3, 7]
    assert [k for k, x in enumerate(s1["reference_sd"]) if x > 0] == [0, length]
    noise = np.concatenate([np.asarray(s["reference_sd"][1:]) for s in (s0, s1)])
    assert out["reference_noise_bits"] == pytest.approx(noise.mean())
    assert out["reference_noise_bits_max"] == pytest.approx(noise.max())
    assert out["band_coverage_dirichlet_ci95"] == pytest.approx(out["band_coverage_ci95"])
    assert out["band_draws"] == 5 and out["states"] == 8
    assert (out["sequences"], out["trials"], out["length"], out["seed"], out["noise"]) == (2, m, length, seed, "none")
    assert out["contact"] == out["model_contact"] == model_scene(model).settings.contact
    assert out["engine"] == out["model_engine"] == model_scene(model).settings.engine
    assert out["steps_compared"] == "1..N (step 0 is the start distribution)"
    assert out["estimator"] == "model curve = expected plug-in entropy of M draws from its report-grid distribution"
    assert out["model_seconds"] > 0 and out["simulation_seconds"] >= 0
    assert set(out) == {
        "engine", "model_engine", "mean_abs_error_bits", "max_abs_error_bits", "median_abs_error_bits", "share_steps_above_0_25",
        "mean_abs_error_bits_exact_curve", "final_tv_distance", "reference_noise_bits", "reference_noise_bits_max",
        "band_coverage", "band_coverage_ci95", "band_coverage_dirichlet", "band_coverage_dirichlet_ci95",
        "band_steps", "band_verdict", "structural_delta", "structural_source", "structural_note",
        "structural_delta_q90", "band_draws", "per_sequence", "sequences", "trials", "length", "seed", "noise",
        "steps_compared", "estimator", "model_seconds", "simulation_seconds", "states", "contact", "model_contact",
        "simulation_spread_bits"}


def _built_mixed_model():
    """8 report cells = 8 states; every tilt sends every state to cell 0 three times in four and to cell 1
    once (counts 3 and 1), so from tilt 1 on the model predicts (0.75, 0.25): 0.811 bits."""
    import scipy.sparse as sp

    scene = scene_from_options("rectangle:20x20")
    grid = ReportGrid(200.0, 200.0, 2, 2, 2, symmetry_order=4)
    n = grid.n_voxels
    rows, cols = np.repeat(np.arange(n), 2), np.tile([0, 1], n)
    mats = [sp.csr_matrix((np.tile([0.75, 0.25], n), (rows, cols)), shape=(n, n)) for _ in scene.actions]
    extras = {f"counts_{a}": np.tile([3, 1], n).astype(np.int64) for a in range(len(scene.actions))}
    md = {"kind": "kruskal.built_model", "stats": {"states": n}, "scene": scene.to_dict(), "grid": grid.to_dict(),
          "noise": "none"}
    return TransitionModel(list(scene.actions), mats, initial=np.full(n, 1.0 / n), partition=np.arange(n),
                           n_cells=n, metadata=md, extras=extras), grid


def test_band_structural_needs_and_their_quantile_recomputed_from_their_definitions():
    """A model predicting (0.75, 0.25) against references at 0 bits (all trials in cell 0), 0.811 bits
    (the model), 0.918 bits (two thirds in cell 0) and 1 bit: the band recomputed from its definition
    (posterior draws [seed, 4, r], their sd in quadrature with 1.645 x the reference's bootstrap sd,
    moved by the plug-in bias; the structural term at a given delta of 1, which reaches 0 bits), each
    step's needed delta by
    structural_score, their conformal 90% quantile, and both coverages with their Wilson intervals."""
    from analysis.validate import coverage_verdict
    from kruskal_markov.entropy import entropy_trajectory
    from kruskal_markov.posterior import resample_model
    from kruskal_markov.structural import band_with_structure, conformal_quantile, structural_score

    model, grid = _built_mixed_model()
    length, m, seed, bands = 12, 60, 3, 8
    patterns = [[0], [0, 0, 0, 1], [0, 0, 1], [0, 1]]

    def fake(scene, seq, trials, sd, noise):
        i = fake.calls
        fake.calls += 1
        steps = [list(range(8))] + [patterns[(k + i) % 4] for k in range(length)]
        return _fake_reference(grid, steps, trials)
    fake.calls = 0
    out = validate_model(model, sequences=3, trials=m, seed=seed, length=length, bands=bands, simulate=fake,
                         structural_delta=1.0)
    assert (out["structural_delta"], out["structural_source"]) == (1.0, "given")
    draws = [resample_model(model, np.random.default_rng([seed, 4, r])) for r in range(bands)]
    ins, ins_dir, need_all = [], [], []
    for s in out["per_sequence"]:
        seq = [model.actions.index(a) for a in s["sequence"]]
        tr = entropy_trajectory(model, seq, return_distributions=True)
        cells = np.asarray(tr.distributions)
        curves = np.stack([entropy_trajectory(d, seq).entropy_bits for d in draws])
        matched, exact = np.asarray(s["model"]), np.asarray(s["model_exact"])
        assert exact[1:] == pytest.approx([0.8112781244591328] * length)
        centre = curves.mean(0) + matched - exact
        width = 1.6448536269514722 * np.sqrt(curves.std(0, ddof=1) ** 2 + np.asarray(s["reference_sd"]) ** 2)
        assert s["band_centre"] == pytest.approx(centre.tolist()) and s["band_width"] == pytest.approx(width.tolist())
        lo, hi = band_with_structure(cells, centre, width, 1.0)
        assert s["band_lo"] == pytest.approx(lo.tolist()) and s["band_hi"] == pytest.approx(hi.tolist())
        href = np.asarray(s["reference"])
        need = structural_score(cells, centre, width, href)
        assert s["structural_needed"] == pytest.approx([x if np.isfinite(x) else None for x in need.tolist()])
        inside = (href >= lo - 1e-12) & (href <= hi + 1e-12)
        inside_dir = (href >= centre - width - 1e-12) & (href <= centre + width + 1e-12)
        assert s["band_coverage"] == pytest.approx(inside[1:].mean())
        assert s["band_coverage_dirichlet"] == pytest.approx(inside_dir[1:].mean())
        ins.append(inside[1:])
        ins_dir.append(inside_dir[1:])
        need_all.append(need[1:])
    ins, ins_dir, need_all = map(np.concatenate, (ins, ins_dir, need_all))
    q = conformal_quantile(need_all, 0.9)
    assert 0 < q < np.inf and out["structural_delta_q90"] == pytest.approx(q)
    assert out["band_steps"] == 3 * length
    assert out["band_coverage"] == pytest.approx(ins.mean()) and out["band_coverage_dirichlet"] == pytest.approx(
        ins_dir.mean())
    assert ins.sum() > ins_dir.sum()                       # the structural term holds steps the Dirichlet band misses
    assert out["band_coverage_ci95"] == pytest.approx(list(wilson_interval(int(ins.sum()), len(ins))))
    assert out["band_coverage_dirichlet_ci95"] == pytest.approx(list(wilson_interval(int(ins_dir.sum()), len(ins))))
    assert out["band_verdict"] == coverage_verdict(int(ins.sum()), len(ins))


def test_the_documented_defaults_and_the_smallest_counts():
    """validate_model(model) runs 6 sequences of 50 tilts, 1,000 trials each, seed 0, a 40-draw band;
    2 trials, 1 sequence, 1 tilt and no band are the smallest counts allowed."""
    from analysis.sequences import random_sequences_for

    model, grid = _built_point_model()
    seen = []

    def fake(scene, seq, trials, sd, noise):
        seen.append((list(seq), trials, sd))
        return _fake_reference(grid, [list(range(8))] + [[0]] * len(seq), trials)

    out = validate_model(model, simulate=fake)
    assert (out["sequences"], out["trials"], out["seed"], out["length"], out["band_draws"]) == (6, 1000, 0, 50, 40)
    assert [s for s, _, _ in seen] == [list(q) for q in random_sequences_for(model.n_actions, 6, 50, 0)]
    assert {t for _, t, _ in seen} == {1000} and [sd for *_, sd in seen] == [reference_seed(0, i) for i in range(6)]
    small = validate_model(model, sequences=1, trials=2, length=1, bands=0, simulate=fake)
    assert (small["sequences"], small["trials"], small["length"], small["band_draws"]) == (1, 2, 1, 0)
    assert small["band_coverage"] is None and small["structural_delta_q90"] is None and small["band_verdict"] is None


def test_the_share_of_steps_above_a_quarter_bit_is_strict_at_its_threshold():
    """A model at 0 bits against references of 200 trials: 9 of them in cell 1 is H(0.955) = 0.265 bits,
    above 0.25; 8 is H(0.96) = 0.242, below; so 1 step of 4 is above a quarter bit."""
    model, grid = _built_point_model()

    def fake(scene, seq, trials, sd, noise):
        return _fake_reference(grid, [list(range(8)), [0], [0] * 191 + [1] * 9, [0] * 192 + [1] * 8, [0]], trials)

    out = validate_model(model, sequences=1, trials=200, length=4, bands=0, simulate=fake)
    err = out["per_sequence"][0]["reference"][1:]
    assert err == pytest.approx([0.0, 0.2648, 0.2423, 0.0], abs=1e-4)
    assert out["share_steps_above_0_25"] == 0.25 and out["max_abs_error_bits"] == pytest.approx(err[1])


def test_bad_input_errors_are_whole_lines():
    import re

    model, grid = _built_point_model()
    for bad in (-0.1, True, float("nan"), float("inf"), "0.1"):
        with pytest.raises(ValueError, match="^" + re.escape(f"structural_delta must be a non-negative number, got {bad!r}")
                           + "$"):
            validate_model(model, structural_delta=bad, simulate=lambda *a: None)
    plain = TransitionModel(["N"], [np.eye(2)])
    with pytest.raises(ModelError, match=r"^the model records no scene \(only models from `kruskal build` can be "
                                         r"validated\)$"):
        model_scene(plain)
    with pytest.raises(ModelError, match="^the model records no report grid$"):
        model_grid(TransitionModel(["N"], [np.eye(2)], metadata={"scene": model.metadata["scene"]}))
    off_grid = TransitionModel(model.actions, model.matrices, initial=model.initial, partition=np.arange(8) % 4,
                               n_cells=4, metadata=model.metadata, extras=model.extras)
    with pytest.raises(ModelError, match="^the model's partition is not on its report grid$"):
        validate_model(off_grid, simulate=lambda *a: None)
    # a structural delta of 0 is allowed: the Dirichlet band alone
    out = validate_model(model, sequences=1, trials=2, length=1, bands=2, structural_delta=0,
                         simulate=lambda sc, sq, m, sd, nz: _fake_reference(grid, [list(range(8)), [0]], m))
    assert (out["structural_delta"], out["structural_source"]) == (0.0, "given")


def _validate_shift_model(final_cells):
    """``validate_model`` on a model that moves the part one cell on at every tilt (state i -> i + 1 mod 8,
    from cell 0; 5 tilts), against references that follow it and end in ``final_cells[i]`` (one per sequence)."""
    import scipy.sparse as sp

    model, grid = _built_point_model()
    n = 8
    mats = [sp.csr_matrix((np.ones(n), (np.arange(n), (np.arange(n) + 1) % n)), shape=(n, n)) for _ in model.actions]
    shift = TransitionModel(model.actions, mats, initial=np.eye(n)[0], partition=np.arange(n), n_cells=n,
                            metadata=model.metadata, extras=model.extras)
    length = 5

    def fake(scene, seq, trials, sd, noise):
        i = fake.calls
        fake.calls += 1
        return _fake_reference(grid, [[k % n] for k in range(length)] + [[final_cells[i]]], trials)
    fake.calls = 0
    return validate_model(shift, sequences=len(final_cells), trials=10, length=length, bands=0, simulate=fake)


def test_final_total_variation_compares_the_last_step():
    """A model that moves the part one cell on at every tilt (state i -> i + 1 mod 8, from cell 0): after
    5 tilts it is in cell 5. A reference in cell 5 at the end is at total variation 0, one in cell 6 at
    1 (whatever the earlier steps); the mean over the two sequences is 0.5."""
    out = _validate_shift_model([5, 6])
    assert [s["final_tv_distance"] for s in out["per_sequence"]] == [0.0, 1.0]
    assert out["final_tv_distance"] == 0.5 and out["mean_abs_error_bits"] == 0.0


def test_a_reference_above_the_band_by_a_tenth_is_outside():
    """``_inside`` holds a step when the reference lies in [lo, hi] (to 1e-12): 1.1 above a band [0, 1] is
    outside, as is -0.1 below it; the ends themselves are inside."""
    from analysis.validate import _inside

    x = np.array([1.1, 1.0, 0.5, 0.0, -0.1])
    assert _inside(x, np.zeros(5), np.ones(5)).tolist() == [False, True, True, True, False]


def test_final_total_variation_is_the_mean_over_sequences_not_the_median():
    """The model of the test above (one cell on per tilt: in cell 5 after 5 tilts), three sequences whose
    references end in cells 5, 6 and 5: total variations 0, 1 and 0, their mean 1/3 (the median would say 0)."""
    out = _validate_shift_model([5, 6, 5])
    assert [s["final_tv_distance"] for s in out["per_sequence"]] == [0.0, 1.0, 0.0]
    assert out["final_tv_distance"] == pytest.approx(1 / 3)


def test_model_grid_reads_each_field_of_the_recorded_grid_from_its_own_key():
    """A recorded grid whose seven fields all differ (300 x 200 mm, 3 x 5 x 7 cells, symmetry order 2, angle
    offset 0.1 rad) comes back field for field: no field is read from another's key."""
    grid = ReportGrid(300.0, 200.0, 3, 5, 7, symmetry_order=2, theta_offset=0.1)
    built = TransitionModel(["N"], [np.eye(2)], metadata={"grid": grid.to_dict()})
    assert model_grid(built).to_dict() == grid.to_dict() == {
        "tray_x_mm": 300.0, "tray_y_mm": 200.0, "nx": 3, "ny": 5, "ntheta": 7, "symmetry_order": 2,
        "theta_offset": 0.1}


def test_the_random_sequences_are_over_the_models_actions_not_its_cells():
    """On a model with 8 actions and 12 report cells, the validated sequences are
    ``random_sequences_for(8 actions, sequences, length, seed)``, named by the model's actions."""
    import scipy.sparse as sp

    from analysis.sequences import random_sequences_for

    scene = scene_from_options("rectangle:20x20")
    grid = ReportGrid(200.0, 200.0, 3, 2, 2, symmetry_order=4)
    n = grid.n_voxels
    mats = [sp.csr_matrix((np.ones(n), (np.arange(n), np.zeros(n, dtype=int))), shape=(n, n)) for _ in scene.actions]
    md = {"kind": "kruskal.built_model", "stats": {"states": n}, "scene": scene.to_dict(), "grid": grid.to_dict(),
          "noise": "none"}
    model = TransitionModel(list(scene.actions), mats, initial=np.full(n, 1.0 / n), partition=np.arange(n),
                            n_cells=n, metadata=md)
    assert (model.n_actions, model.n_cells) == (8, 12)
    length = 6
    out = validate_model(model, sequences=3, trials=4, length=length, seed=9, bands=0,
                         simulate=lambda scene, seq, trials, sd, noise: _fake_reference(grid, [[0]] * (length + 1),
                                                                                        trials))
    want = [[scene.actions[a] for a in s] for s in random_sequences_for(8, 3, length, 9)]
    assert [s["sequence"] for s in out["per_sequence"]] == want


def test_the_dirichlet_band_is_the_centre_plus_or_minus_the_width():
    """With 10 trials the plug-in bias moves the band's centre below the model's exact curve at most steps.
    References placed there (by their entropies; the trials, and so the band, unchanged) halfway between the
    band's lower end ``centre - width`` and ``exact - width``, elsewhere at the centre, are inside the
    Dirichlet band at every step: 100%."""
    model, grid = _built_mixed_model()
    length, m, seed = 4, 10, 3
    steps = [list(range(8))] + [[0, 0, 0, 1]] * length

    def fake(h=None):
        def simulate(scene, seq, trials, sd, noise):
            ref = _fake_reference(grid, steps, trials)
            if h is not None:
                ref.entropy_bits = np.asarray(h)
            return ref
        return simulate
    first = validate_model(model, sequences=1, trials=m, seed=seed, length=length, bands=8, simulate=fake(),
                           structural_delta=0.0)["per_sequence"][0]
    centre, width, exact = (np.asarray(first[k]) for k in ("band_centre", "band_width", "model_exact"))
    below = exact - centre > 0.01
    assert below[1:].sum() >= 2
    h = np.where(below, centre - width + 0.5 * (exact - centre), centre)
    h[0] = first["reference"][0]
    second = validate_model(model, sequences=1, trials=m, seed=seed, length=length, bands=8, simulate=fake(h),
                            structural_delta=0.0)["per_sequence"][0]
    assert second["band_centre"] == pytest.approx(first["band_centre"])
    assert second["band_width"] == pytest.approx(first["band_width"])
    assert second["band_coverage_dirichlet"] == 1.0

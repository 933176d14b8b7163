"""The report's tray-log section with the static/kinetic pair and the log's design (issue 57, item 6).

One small run of :func:`analysis.fit.study.tray_log_study` on the planar engine (a 60 x 20 mm
rectangle in a 120 x 100 mm tray, 3 mm / 3 degree builds of 100 start samples, 80 trials of 6 tilts,
coarse grids: 3 models for the single fit, 20 for the pair, 3 for the design): the keys, the pair's hidden truth against its stream, every number the section prints
recomputed from the saved results, the design's recommendation among its candidates, the figures;
then a non-coulomb scene skips the pair (and the planar design) with a sentence, and the text of a
fit across physics names both engines.
"""
from __future__ import annotations

import math
import os

import pytest

from analysis.streams import salted_rng

SEED, TRIALS, TILTS, CAMERA = 5, 80, 6, (0.5, 0.5)
Z90 = 1.6448536


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    from analysis.fit.core import FitSettings
    from analysis.fit.design import DesignSettings
    from analysis.fit.study import tray_log_study
    from analysis.fit.study_pair import pair_fit_settings
    from transition_builder.builder import BuildSettings
    from transition_builder.scene import scene_from_options

    d = tmp_path_factory.mktemp("tray_log")
    old = os.environ.get("KRUSKAL_CACHE")
    os.environ["KRUSKAL_CACHE"] = str(d / "cache")
    try:
        scene = scene_from_options("rectangle:60x20", engine="planar", tray_mm=(120, 100))
        bs = BuildSettings(tol_mm=3, tol_deg=3, recenter_rounds=0, start_samples=100, seed=0)
        points = {"mu": 3, "noise": 3, "mu_s": 3, "mu_k": 3}
        fs = FitSettings(points=points, refine=0, bootstrap=50, gof_draws=20, camera=CAMERA, seed=SEED,
                         replicates=0, gof_sibling=False)
        ps = pair_fit_settings(SEED, CAMERA, points={**points, "mu_s": 4, "mu_k": 4}, refine=1, bootstrap=50,
                               gof_draws=20, gof_sibling=False)
        ds = DesignSettings(at=(0.3,), sequences=2, tilts=TILTS, trials=TRIALS, simulated=50, camera=CAMERA,
                            seed=SEED)
        st = tray_log_study(scene, SEED, trials=TRIALS, tilts=TILTS, camera=CAMERA, fit_settings=fs,
                            build_settings=bs, workers=1, count=20, pair=True, design=True, pair_settings=ps,
                            design_settings=ds)
        figures = st.figures(str(d))
    finally:
        if old is None:
            os.environ.pop("KRUSKAL_CACHE", None)
        else:
            os.environ["KRUSKAL_CACHE"] = old
    return st, figures


def _row(md: str, name: str) -> list[str]:
    """The cells of the markdown table row whose first cell is ``name``."""
    line = next(ln for ln in md.splitlines() if ln.startswith(f"| {name} |"))
    return [c.strip() for c in line.strip("|").split("|")]


def test_keys_and_results_json(study):
    import json

    from analysis.commands import strict_json

    st, _ = study
    d = json.loads(strict_json(st.to_dict()))
    assert {"pair", "design", "pair_skipped", "design_skipped", "truth", "fit"} <= set(d)
    assert d["pair_skipped"] is None and d["design_skipped"] is None
    assert set(d["pair"]["fit"]["estimate"]) == {"mu_s", "mu_k"}
    assert d["pair"]["fit"]["camera_noise"]["estimated"] is False and d["pair"]["camera"] == list(CAMERA)
    assert d["pair"]["log_engine"] == d["pair"]["models_engine"] == "planar"
    assert {"candidates", "recommended"} <= set(d["design"]) and d["design"]["engine"] == "planar"


def test_the_pairs_hidden_truth_sequence_and_starts_are_the_streams_draws(study):
    st, _ = study
    rng = salted_rng(SEED, "tray_log", 2)
    k = rng.uniform(0.15, 0.35)
    s = k + rng.uniform(0.0, 0.15)
    assert st.pair["truth"] == {"mu_s": round(s, 3), "mu_k": round(k, 3)}
    actions = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")
    seq = salted_rng(SEED, "tray_log", 3).integers(0, 8, TILTS)
    assert st.pair["sequence"] == [actions[a] for a in seq] != st.sequence
    assert st.pair["log_seed"] == int(salted_rng(SEED, "tray_log", 4).integers(0, 2 ** 31))
    assert st.pair["fit"]["trials"] == TRIALS and st.pair["fit"]["tilts"] == TILTS


def test_every_number_of_the_pair_is_recomputed(study):
    st, _ = study
    md, p = st.markdown(), st.pair
    f, t = p["fit"], p["truth"]
    iv = f["interval_90"] or {}
    cal = f["calibration"]                   # the section calibrates the pair (PAIR_CALIBRATION_LOGS logs)
    assert cal["logs"] == 9 and f"{cal['logs']} logs simulated by" in md
    gap_iv = cal["difference_interval_90"]
    assert iv and gap_iv                     # not at the range's edge: the covers/misses words are printed

    def words(i, v):
        return "-" if i is None else ("covers" if i[0] <= v <= i[1] else "misses")

    def interval(i):
        return "none (at the range's edge)" if i is None else f"{i[0]:.4f}..{i[1]:.4f}"

    for name, tv, ev, i in (("mu_s", t["mu_s"], f["estimate"]["mu_s"], iv.get("mu_s")),
                            ("mu_k", t["mu_k"], f["estimate"]["mu_k"], iv.get("mu_k")),
                            ("mu_s - mu_k", t["mu_s"] - t["mu_k"], f["estimate"]["mu_s"] - f["estimate"]["mu_k"],
                             gap_iv)):
        assert _row(md, name) == [name, f"{tv:.3f}", f"{ev:.4f}", interval(i), words(i, tv)]
    assert f"mu_s = {t['mu_s']:.3f}, mu_k = {t['mu_k']:.3f}" in md
    assert f"{TRIALS} trials of its own random {TILTS}-tilt sequence" in md
    assert f"fitted it on {len(f['models'])} models built by the planar engine" in md
    gof = f["goodness_of_fit"]
    assert f"Goodness of fit: {gof['verdict']} (p = {gof['test']['p_value']:.3f})" in md


def test_every_number_of_the_design_is_recomputed(study):
    st, _ = study
    md, d = st.markdown(), st.design
    cands = d["candidates"]
    assert [c["designed"] for c in cands] == [False, False, True]
    for label, c in zip(("random 1", "random 2", "designed"), cands):
        info = c["information_per_trial"]
        width = 2 * Z90 / math.sqrt(TRIALS * info)
        assert _row(md, label) == [label, f"{info:.3g}", f"{width:.2g}"]
    best = max(cands, key=lambda c: c["information_per_trial"])
    label = ("random 1", "random 2", "designed")[cands.index(best)]
    assert d["recommended"]["sequence"] == best["sequence"]            # the recommendation is a candidate
    n = math.ceil((2 * Z90 / 0.02) ** 2 / best["information_per_trial"])
    w = 2 * Z90 / math.sqrt(n * best["information_per_trial"])
    reach = "reaches" if n == 1 else "reach"
    assert (f"Recommended: {label} (`{','.join(best['sequence'])}`); {n} trial{'s' if n != 1 else ''} {reach} "
            f"the target 90% width of 0.02 (predicted {w:.2g})") in md
    assert f"predicted 90% width at {TRIALS} trials" in md and f"--seed {SEED}`" in md
    assert f"{len(d['models'])} models of the planar engine at mu = 0.3 and +-0.025" in md
    iv, only = st.fit["interval_90"]["mu"], st.fit["interval_90_trials_only"]["mu"]
    assert (f"its 90% interval is {iv[1] - iv[0]:.4f} wide, its trials-only interval {only[1] - only[0]:.4f}"
            in md)


def test_figures_include_the_pairs_heat_map(study):
    _, figures = study
    assert [os.path.basename(f) for f in figures] == ["fig_tray_log.png", "fig_tray_log_pair.png"]
    for f in figures:
        with open(f, "rb") as fh:
            assert fh.read(8) == b"\x89PNG\r\n\x1a\n"


def test_a_fit_across_physics_names_both_engines(study):
    import dataclasses

    st, _ = study
    across = dataclasses.replace(st, pair={**st.pair, "log_engine": "pybullet"})
    md = across.markdown()
    assert "made by direct simulation in PyBullet" in md and "models built by the planar engine" in md
    assert "The log is PyBullet's physics and the models the planar engine's: a fit across physics." in md
    assert "The log and the models are both the planar engine's physics." in st.markdown()


def test_a_non_coulomb_scene_skips_the_pair_and_the_planar_design(study):
    import dataclasses

    from analysis.fit.design import DesignSettings
    from analysis.fit.study_design import design_study
    from analysis.fit.study_pair import pair_study
    from transition_builder.scene import scene_from_options

    scene = scene_from_options("rectangle:60x20", contact="sphere", tray_mm=(120, 100))
    pair, why = pair_study(scene, SEED, trials=TRIALS, tilts=TILTS, camera=CAMERA)
    assert pair is None and "sphere contact" in why and "needs the coulomb contact" in why
    design, why_d = design_study(scene, DesignSettings(at=(0.3,), sequences=1, tilts=3, seed=SEED))
    assert design is None and "coulomb contact only" in why_d
    st, _ = study
    skipped = dataclasses.replace(st, pair=None, pair_skipped=why, design=None, design_skipped=why_d)
    md = skipped.markdown()
    assert why in md and why_d in md and "| mu_s |" not in md
    assert skipped.to_dict()["pair"] is None and skipped.to_dict()["design"] is None


def test_the_reports_settings_switch_the_pair_and_the_design():
    import dataclasses

    from analysis.experiments.tray_log import Settings
    from analysis.reproduce import ReproduceSettings

    off = Settings.from_settings(ReproduceSettings())
    assert (off.pair, off.design, off.models_engine) == (False, False, "planar")
    full = Settings.from_settings(ReproduceSettings.full())
    assert full.enabled and full.pair and full.design and full.models_engine == "planar"
    with pytest.raises(ValueError, match="unknown engine"):
        Settings.from_settings(dataclasses.replace(ReproduceSettings.full(), tray_log_models_engine="bogus"))

"""How sure are the answers? The key's answers with their intervals, the validation band's coverage,
and how much the answers depend on the physics' settings: time step, pose noise, friction
(``sensitivity``).

The key's model is rebuilt (at the report's compared resolution) under each setting, and the same
answers are computed from each model (:class:`~analysis.experiments.model_answers.ModelAnswers`):
the converging share of random 50-tilt sequences, the mean entropy at tilts 10, 20 and 50, the
expected random tilts to converge, the shortest one-cell plan, and how many of experiment A's 43
sequences converge (the paper: 29). A conclusion *survives* when it holds under every setting; an
answer is *only as good as a setting* when the settings move it by more than its own model interval.

The floor's friction coefficient gets a curve of its own: the answers over ``mu`` from the models,
checked at a few coefficients by direct simulation of experiment A's first sequences (the paper
does not state its coefficient; the curve says which one reproduces its experiment A).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from analysis.experiments.model_answers import key_metrics, model_answers
from analysis.experiments.paper import PAPER
from analysis.experiments.plotting import pyplot, save
from analysis.experiments.text import interval

_ANSWERS = ("converging_share", "mean_entropy_10", "mean_entropy_20", "mean_entropy_50", "random_tilts")
_ANSWER_LABELS = {"converging_share": "converging share (50 tilts)", "mean_entropy_10": "mean entropy at tilt 10 (bits)",
                  "mean_entropy_20": "mean entropy at tilt 20 (bits)", "mean_entropy_50": "mean entropy at tilt 50 (bits)",
                  "random_tilts": "expected random tilts to converge"}


@dataclasses.dataclass(frozen=True)
class Settings:
    """Whether the study runs; the pose noises and floor friction coefficients the key is rebuilt
    under (at ``contact_build``); the direct checks of the friction curve."""

    enabled: bool
    noise: tuple
    mu: tuple
    check_mu: tuple
    check_sequences: int
    check_trials: int
    build: dict
    sync_time_budget: float

    @classmethod
    def from_settings(cls, s) -> "Settings":
        return cls(s.sensitivity, tuple(s.sensitivity_noise), tuple(s.sensitivity_mu), tuple(s.sensitivity_check_mu),
                   s.sensitivity_check_sequences, s.sensitivity_check_trials,
                   dict(s.key_build if s.contact_build is None else s.contact_build), s.part_sync_time_budget)


@dataclasses.dataclass(frozen=True)
class Result:
    """The study (None when not run) beside the key's answer intervals and its validation."""

    settings: Settings
    study: dict | None
    key_intervals: dict | None
    validation: dict

    def to_dict(self) -> dict:
        return {} if self.study is None else {"sensitivity": self.study}


def _direct_check(ctx, scene, sequences, names, trials) -> dict:
    """A's first sequences in direct simulation: how many end at zero entropy, and the mean curve."""
    from analysis.montecarlo import run_direct

    curves, tilts, faults = [], 0, {}
    for i, seq in enumerate(sequences):
        res = run_direct(scene, [names[a] for a in seq], trials, seed=ctx.seed(f"sensitivity.check:{i}"),
                         workers=ctx.workers)
        curves.append(res.entropy_bits)
        tilts += int(res.tilts_simulated)
        for k, v in res.faults.items():
            faults[k] = faults.get(k, 0) + int(v)
    c = np.array(curves)
    return {"sequences": len(sequences), "trials": int(trials), "ended_at_zero": int(np.sum(c[:, -1] <= 0.0)),
            "mean": c.mean(axis=0).tolist(), "tilts": tilts, "faults": faults}


def _answers(ctx, model, st: Settings) -> dict:
    m = key_metrics(ctx, model, sync_time_budget=st.sync_time_budget, draws=0)
    return model_answers(ctx, model, m, intervals=True).interval_dict()


def _friction_checks(ctx, st: Settings, models: dict, mu_scene, mu0) -> dict:
    s = ctx.settings
    default = models["default"]
    a_seqs = ctx.ensemble(default, s.a_sequences, "A", keep_entropy=True).sequences[:st.check_sequences]
    checks = {}
    for mu in map(float, st.check_mu):
        ctx.log(f"sensitivity: mu {mu:g}: {len(a_seqs)} sequences of A in direct simulation "
                f"({st.check_trials} trials)")
        direct = _direct_check(ctx, mu_scene(mu), a_seqs, default.actions, st.check_trials)
        m = models["default" if mu == mu0 else f"mu {mu:g}"]
        ens = ctx.ensemble(m, len(a_seqs), "A", keep_entropy=True)
        assert np.array_equal(ens.sequences, a_seqs)
        checks[f"{mu:g}"] = {"direct": direct, "model_mean": ens.mean.tolist(), "model_converged": int(ens.converged),
                             "model_ended_at_zero": int(np.sum(ens.entropy[:, -1] <= s.epsilon))}
    return checks


def sensitivity_study(ctx, st: Settings) -> dict:
    """Answers of the key's model under every setting of ``st`` (see the module docstring).

    Returns
    -------
    dict
        ``settings`` (label -> answers and model info), ``friction_curve`` (mu -> answers),
        ``friction_checks`` (mu -> direct simulation and the model on the same sequences),
        ``conclusions``, ``paper_mu`` and ``seconds``.
    """
    t0 = ctx.clock()
    key_scene = ctx.scene()
    mu0 = float(key_scene.friction.mu)
    variants = [("default", key_scene, {}),
                ("half time step", key_scene.with_settings(**key_scene.settings.finer_step(2)), {})]
    variants += [(f"noise {n.split(':')[1]}", key_scene, {"noise": n}) for n in st.noise]
    mus = sorted(set(float(m) for m in st.mu) | {mu0})

    def mu_scene(mu):
        return key_scene if mu == mu0 else ctx.scene(friction_spec=str(mu))

    variants += [(f"mu {mu:g}", mu_scene(mu), {}) for mu in mus if mu != mu0]
    table, models = {}, {}
    for label, scene, changes in variants:
        model, info = ctx.build(scene, {**st.build, **changes}, f"sensitivity: {label}")
        ctx.log(f"sensitivity: {label}: answers")
        table[label] = {**_answers(ctx, model, st), "model": info.to_dict()}
        models[label] = model
    curve = {f"{mu:g}": table["default" if mu == mu0 else f"mu {mu:g}"] for mu in mus}
    checks = _friction_checks(ctx, st, models, mu_scene, mu0)
    return {"settings": table, "friction_curve": curve, "friction_checks": checks,
            "conclusions": conclusions(table), "paper_mu": paper_mu(curve), "seconds": ctx.clock() - t0}


def run(ctx) -> Result:
    st = Settings.from_settings(ctx.settings)
    key = ctx.result("key")
    km = ctx.result("sync").metrics
    study = sensitivity_study(ctx, st) if st.enabled else None
    return Result(st, study, km.intervals, key.validation)


def conclusions(table: dict) -> dict:
    """Per answer: its range over the settings, the largest relative move from the default, and
    whether the move exceeds the default's own model interval; and the yes/no conclusions."""
    d = table["default"]
    out = {}
    for k in _ANSWERS:
        vals = {lab: t[k]["value"] for lab, t in table.items() if t.get(k) and t[k].get("value") is not None}
        v0 = d[k]["value"] if d.get(k) else None
        if v0 is None or not vals:
            continue
        lo, hi = d[k]["model_ci90"]
        moves = {lab: (v - v0) / v0 if v0 else None for lab, v in vals.items()}
        out[k] = {"default": v0, "min": min(vals.values()), "max": max(vals.values()),
                  "largest_relative_move": max((abs(m) for m in moves.values() if m is not None), default=None),
                  "moved_beyond_model_interval": sorted(lab for lab, v in vals.items() if not lo <= v <= hi)}
    plans = [t["cell_plan"]["length"] for t in table.values()]
    shares = [t["converging_share"]["value"] for t in table.values()]
    out["random tilts orient the key (converging share > 0 under every setting)"] = bool(min(shares) > 0)
    out["a one-cell plan exists under every setting"] = bool(all(p is not None for p in plans))
    out["cell plan lengths"] = plans
    return out


def paper_mu(curve: dict) -> dict:
    """The coefficient whose model converges on as many of A's 43 sequences as the paper (29)."""
    target = PAPER["A"]["converged"]
    best = min(curve, key=lambda mu: abs(curve[mu]["a_converged"] - target))
    return {"paper_a_converged": target, "closest_mu": float(best),
            "a_converged_by_mu": {mu: c["a_converged"] for mu, c in curve.items()}}


# --- the report's section ---------------------------------------------------------------------------
def _intervals_lines(iv: dict | None, v: dict) -> list[str]:
    lines = ["## How sure are these answers?", "",
             "Every answer of the key's model with three intervals (`docs/uncertainty.md`): the Monte Carlo "
             "interval of its estimate from finitely many random sequences; the posterior interval (the "
             "answer over draws of the model's rows from their Dirichlet posterior); and the model interval, "
             "which adds the model's structural error: every report-cell distribution within a total-variation "
             f"distance of {iv['settings']['structural_delta'] if iv else '-'} times the probability outside the "
             "most likely cell, a bound calibrated on held-out validation runs.", "",
             "| answer | value | Monte Carlo 95% | posterior 90% | model 90% (with structure) |", "|---|---|---|---|---|"]
    if iv:
        for k, label in _ANSWER_LABELS.items():
            e = iv.get(k)
            if e and e.get("value") is not None:
                lines.append(f"| {label} | {e['value']:.3g} | {interval(e['mc_ci95'])} | "
                             f"{interval(e['posterior_ci90'])} | {interval(e['model_ci90'])} |")
    if v.get("band_coverage") is not None and v.get("band_coverage_ci95"):
        lo, hi = v["band_coverage_ci95"]
        dlo, dhi = v.get("band_coverage_dirichlet_ci95") or (None, None)
        lines += ["", f"The validation above ({v['sequences']} sequences, M = {v['trials']}): the model's 90% band "
                  f"holds direct simulation at {100 * v['band_coverage']:.0f}% of {v['band_steps']} steps "
                  f"(95% interval {100 * lo:.0f}-{100 * hi:.0f}%); the Dirichlet band alone, which knows only "
                  f"sampling noise, at {100 * v['band_coverage_dirichlet']:.0f}%"
                  + (f" ({100 * dlo:.0f}-{100 * dhi:.0f}%)" if dlo is not None else "")
                  + ". Held-out coverage at M = 2,000 is in `docs/uncertainty.md`."]
    return lines


def _table_lines(st: dict) -> list[str]:
    labels = list(st)
    lines = ["", "**Sensitivity to the physics' settings.** The key rebuilt at the compared resolution "
             "(1 mm / 1 degree) under half the time step, pose noise and other floor friction coefficients; "
             "each cell is the answer and its model 90% interval.", "",
             "| answer | " + " | ".join(f"`{k}`" for k in labels) + " |", "|---|" + "---|" * len(labels)]
    for k, label in _ANSWER_LABELS.items():
        cells = []
        for lab in labels:
            e = st[lab].get(k)
            cells.append("-" if not e or e.get("value") is None else f"{e['value']:.3g} ({interval(e['model_ci90'])})")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    lines.append("| shortest one-cell plan (tilts) | " + " | ".join(
        f"{st[lab]['cell_plan']['length'] if st[lab]['cell_plan']['length'] is not None else '-'}"
        + ("" if st[lab]["cell_plan"]["exact"] else " (not proven)") for lab in labels) + " |")
    lines.append(f"| A: of {st['default']['a_sequences']} sequences converging (paper: 29) | "
                 + " | ".join(str(st[lab]["a_converged"]) for lab in labels) + " |")
    lines.append("| model states | " + " | ".join(f"{st[lab]['states']:,}" for lab in labels) + " |")
    return lines


def _conclusion_lines(c: dict) -> list[str]:
    survive = [k for k, val in c.items() if isinstance(val, bool) and val]
    fail = [k for k, val in c.items() if isinstance(val, bool) and not val]
    moved, held = [], []
    for k in _ANSWER_LABELS:
        if k not in c or c[k]["largest_relative_move"] is None:
            continue
        outside = c[k]["moved_beyond_model_interval"]
        text = f"{_ANSWER_LABELS[k]} (moves up to {100 * c[k]['largest_relative_move']:.0f}%"
        if outside:
            moved.append(text + f"; outside the default's model interval under {', '.join(outside)})")
        else:
            held.append(text + ")")
    return ["", "Conclusions that survive every setting: " + ("; ".join(survive) if survive else "none") + "."
            + (" Conclusions that do not: " + "; ".join(fail) + "." if fail else ""), "",
            "Numbers that stay within the default's model interval under every setting: "
            + ("; ".join(held) if held else "none") + ".", "",
            "Numbers that are only as good as a setting: " + ("; ".join(moved) if moved else "none") + ".", ""]


def _friction_lines(sens: dict) -> list[str]:
    pm = sens["paper_mu"]
    lines = ["**Friction.** The paper does not state its floor's coefficient. Of experiment A's 43 sequences the "
             "models converge on " + ", ".join(f"{n} at mu = {mu}" for mu, n in pm["a_converged_by_mu"].items())
             + f"; the paper's {pm['paper_a_converged']} is closest at **mu = {pm['closest_mu']:g}**. Checked "
             "by direct simulation of A's first sequences:", "",
             "| mu | sequences x trials | ended at zero entropy: direct / model | mean entropy at tilts 10 / 20 / 50: "
             "direct | model |", "|---|---|---|---|---|"]
    for mu, ch in sens["friction_checks"].items():
        d = ch["direct"]
        at = [t for t in (10, 20, 50) if t < len(d["mean"])]
        lines.append(f"| {mu} | {d['sequences']} x {d['trials']} | {d['ended_at_zero']} / {ch['model_ended_at_zero']} | "
                     + " / ".join(f"{d['mean'][t]:.2f}" for t in at) + " | "
                     + " / ".join(f"{ch['model_mean'][t]:.2f}" for t in at) + " |")
    lines += ["", "![friction](fig_friction.png)", "",
              f"The sensitivity study took {sens['seconds'] / 60:.0f} minutes (builds included).", ""]
    return lines


def markdown(r: Result) -> str:
    if not r.key_intervals and not r.study:
        return ""
    lines = _intervals_lines(r.key_intervals, r.validation)
    if r.study:
        lines += _table_lines(r.study["settings"]) + _conclusion_lines(r.study["conclusions"])
        lines += _friction_lines(r.study)
    return "\n".join(lines)


def figures(r: Result, out: str) -> list[str]:
    if not r.study:
        return []
    curve = r.study["friction_curve"]
    checks = r.study["friction_checks"]
    mus = sorted(curve, key=float)
    fig, axes = pyplot().subplots(1, 2, figsize=(10, 3.6))
    x = [float(m) for m in mus]
    for t, color in ((10, "tab:blue"), (20, "tab:orange"), (50, "tab:green")):
        k = f"mean_entropy_{t}"
        if k not in curve[mus[0]]:
            continue
        y = [curve[m][k]["value"] for m in mus]
        lo = [curve[m][k]["model_ci90"][0] for m in mus]
        hi = [curve[m][k]["model_ci90"][1] for m in mus]
        axes[0].plot(x, y, "o-", color=color, label=f"model, tilt {t}")
        axes[0].fill_between(x, lo, hi, color=color, alpha=0.15)
        for m, c in checks.items():
            first = t == 10 and m == next(iter(checks))
            axes[0].plot(float(m), c["direct"]["mean"][t], "x", color=color, ms=9,
                         label=f"direct, A's first {c['direct']['sequences']}" if first else None)
    axes[0].set_xlabel("floor friction coefficient"), axes[0].set_ylabel("mean entropy (bits)")
    axes[0].legend(fontsize=7), axes[0].set_title("mean entropy of random sequences against friction", fontsize=9)
    axes[1].plot(x, [curve[m]["converging_share"]["value"] for m in mus], "o-", label="model: share of random sequences")
    axes[1].plot(x, [curve[m]["a_converged"] / curve[m]["a_sequences"] for m in mus], "s--",
                 label="model: share of A's 43")
    pa = PAPER["A"]
    axes[1].axhline(pa["converged"] / pa["sequences"], color="grey", ls=":", label="paper: 29 of 43")
    axes[1].set_xlabel("floor friction coefficient"), axes[1].set_ylabel("converging share")
    axes[1].legend(fontsize=7), axes[1].set_title("converging within 50 tilts", fontsize=9)
    return save(fig, out, "fig_friction.png")

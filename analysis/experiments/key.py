"""The key's model and how well it predicts direct simulation (``key_model``, ``validation``)."""
from __future__ import annotations

import dataclasses

import numpy as np

from analysis.experiments.context import ModelInfo
from analysis.experiments.plotting import pyplot, save


@dataclasses.dataclass(frozen=True)
class Settings:
    """The key's shape and the validation's random sequences, trials and length."""

    shape: str
    sequences: int
    trials: int
    length: int

    @classmethod
    def from_settings(cls, s) -> "Settings":
        return cls(s.shape, s.validate_sequences, s.validate_trials, s.validate_length)


@dataclasses.dataclass(frozen=True)
class Result:
    """The key's model and :func:`analysis.validate.validate_model` of it."""

    settings: Settings
    model: ModelInfo
    validation: dict

    def to_dict(self) -> dict:
        return {"key_model": self.model.to_dict(), "validation": self.validation}


def run(ctx) -> Result:
    from analysis.validate import validate_model

    st = Settings.from_settings(ctx.settings)
    model, info = ctx.key_model()
    ctx.log(f"validation: {st.sequences} sequences x {st.length} tilts, M = {st.trials}")
    val = validate_model(model, st.sequences, st.trials, ctx.seed("validation"), st.length, workers=ctx.workers)
    return Result(st, info, val)


def markdown(r: Result) -> str:
    st, km, v = r.settings, r.model, r.validation
    band = (f"; the model's 90% band holds the reference at {100 * v['band_coverage']:.0f}% of steps"
            if v.get("band_coverage") is not None else "")
    return "\n".join([
        "## The key's model",
        "",
        f"{km.states:,} states (`kruskal build --shape {st.shape}`"
        + (f", settings {km.settings}" if km.settings else ", default settings") + "; "
        + ("cached" if km.cached else f"built in {km.seconds:.0f} s") + "). "
        f"Against direct simulation on {st.sequences} random {st.length}-tilt sequences "
        f"(M = {st.trials}): mean error {v['mean_abs_error_bits']:.3f} bits, max "
        f"{v['max_abs_error_bits']:.2f}, {100 * v['share_steps_above_0_25']:.0f}% of steps above 0.25 bits; "
        f"the reference's own sampling noise is {v['reference_noise_bits']:.3f} bits" + band + ".",
        "",
        "![validation](fig_validation.png)",
        "",
    ])


def figures(r: Result, out: str) -> list[str]:
    v = r.validation
    fig, axes = pyplot().subplots(1, len(v["per_sequence"]), figsize=(4.2 * len(v["per_sequence"]), 3.5),
                                  sharey=True, squeeze=False)
    for ax, sq in zip(axes[0], v["per_sequence"]):
        x = np.arange(len(sq["reference"]))
        ax.plot(x, sq["reference"], color="tab:red", label="direct simulation")
        ax.plot(x, sq["model"], color="tab:blue", ls="--", label="model")
        if sq.get("band_lo") is not None:
            ax.fill_between(x, sq["band_lo"], sq["band_hi"], color="tab:blue", alpha=0.2, label="model 90% band")
        ax.set_xlabel("tilt"), ax.legend(fontsize=7)
        ax.set_title(f"max error {sq['max_abs_error_bits']:.2f} bits", fontsize=9)
    axes[0][0].set_ylabel("entropy (bits)")
    return save(fig, out, "fig_validation.png")

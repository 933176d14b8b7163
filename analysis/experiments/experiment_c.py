"""Experiment C (the paper's Fig. 6): A's best sequence on the key over friction maps, by direct
simulation as in the paper (a friction map breaks the tray's symmetry; a model per map would cost
about four key models) (``C``)."""
from __future__ import annotations

import dataclasses

import numpy as np

from analysis.experiments.curves import first_at_most
from analysis.experiments.plotting import pyplot, save, trend_axes

LEVELS = ("low", "medium", "high")


@dataclasses.dataclass(frozen=True)
class Settings:
    """The friction specs (``map:LEVEL:I``) and the direct trials per map."""

    maps: tuple
    trials: int

    @classmethod
    def from_settings(cls, s) -> "Settings":
        return cls(tuple(s.maps), s.c_trials)


@dataclasses.dataclass(frozen=True)
class Result:
    """Per map its direct-simulation summary (with ``zero_at``); per level the statistics."""

    settings: Settings
    maps: dict
    levels: dict
    #: A's best sequence in direct simulation under uniform friction (the text's comparison)
    uniform: dict | None = None

    def of_level(self, level: str) -> list[dict]:
        """The maps of one level."""
        return [m for k, m in self.maps.items() if k.split(":")[1] == level]

    def to_dict(self) -> dict:
        return {"C": {"maps": self.maps, "levels": self.levels}}


def _mean_or_none(values):
    v = [x for x in values if x is not None]
    return float(np.mean(v)) if v else None


def run(ctx) -> Result:
    st = Settings.from_settings(ctx.settings)
    a = ctx.result("A")
    best = a.best_sequence
    maps = {}
    for spec in st.maps:
        ctx.log(f"C: {spec}: best sequence in direct simulation ({st.trials} trials)")
        d = ctx.direct(ctx.scene(friction_spec=spec), best, st.trials, f"C:{spec}")
        d["zero_at"] = first_at_most(d["entropy_bits"], 0.0)
        maps[spec] = d
    levels = {}
    for level in LEVELS:
        group = [m for k, m in maps.items() if k.split(":")[1] == level]
        if group:
            c = np.array([m["entropy_bits"] for m in group])
            levels[level] = {"maps": len(group), "converged": sum(m["zero_at"] is not None for m in group),
                             "mean": c.mean(axis=0).tolist(), "q25": np.quantile(c, 0.25, axis=0).tolist(),
                             "q75": np.quantile(c, 0.75, axis=0).tolist(),
                             "mean_zero_at": _mean_or_none([m["zero_at"] for m in group])}
    return Result(st, maps, levels, a.best_direct)


def markdown(r: Result) -> str:
    uniform = r.uniform
    return "\n".join(["## C: friction noise (direct simulation)", "",
                      "A friction map breaks the tray's rotation symmetry, so each map would need its own full model; "
                      f"C is therefore run as the paper ran it, by direct simulation (M = {r.settings.trials} per map). "
                      + (f"With uniform friction the same sequence ends at {uniform['entropy_bits'][-1]:.2f} bits "
                         f"(M = {uniform['trials']}). " if uniform else "")
                      + f"A zero with M = {r.settings.trials} trials says only that fewer than about "
                      f"{300 / r.settings.trials:.0f}% of parts would end elsewhere (95% confidence).", ""]
                     + (["![C](fig_c_friction.png)", ""] if r.levels else []))


def figures(r: Result, out: str) -> list[str]:
    if not r.levels:
        return []
    fig, axes = pyplot().subplots(1, len(r.levels), figsize=(4.2 * len(r.levels), 3.8), sharey=True, squeeze=False)
    for ax, (level, g) in zip(axes[0], r.levels.items()):
        thin = [m["entropy_bits"] for m in r.of_level(level)]
        trend_axes(ax, thin, g["mean"], g["q25"], g["q75"], f"C: {level} friction noise, {g['maps']} maps",
                   thin_label="map")
    return save(fig, out, "fig_c_friction.png")

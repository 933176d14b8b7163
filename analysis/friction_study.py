"""The paper's experiments A and C explained by friction (issue 40), by direct simulation.

Two questions, both answered in the physics engine (the paper's own method) with the key:

**C as the paper ran it.** The paper generated 20 friction maps and "grouped [them] by their mean
friction" into 13 low, 3 medium and 4 high maps; 10 of 13 low maps converged along its best
sequence, 0 of 3 medium and 0 of 4 high. Our maps all have the mean 0.3 and differ in amplitude
(``map:LEVEL:SEED``), and all converged. Two readings of the same experiment at ``trials`` (M)
starts per map along A's best sequence:

- *amplitude*: today's maps (mean 0.3, amplitude 0.05 / 0.12 / 0.2);
- *mean*: 20 maps of the low amplitude whose means are drawn uniformly from ``mean_range`` (seeded),
  grouped by mean as the paper did: the 13 lowest means are "low", the next 3 "medium", the top 4
  "high".

A map *converges* when the entropy on the report grid is zero at the last tilt (and *reaches* zero
when it is zero at any tilt).

**Which physics reproduces A.** For each candidate physics (a friction spec and a tilt time), K
random 50-tilt sequences (the first K of experiment A's, ``random_sequences_for(8, K, 50, seed)``)
are simulated directly at M starts each. The criterion is ``D = |share - 29/43| + H20 / H0``: the
distance of the share of sequences whose entropy reaches zero from the paper's 29 of 43, plus the
mean entropy at tilt 20 as a fraction of the starting entropy (the paper: "close to zero by the
20th tilt", i.e. 0). Lower is better; 0 is the paper.

**Which physics reproduces B.** For each candidate, the report's B replayed by direct simulation:
A's best sequence of the committed report (:data:`B_SEQUENCE`) on the 15 B parts
(``triangle:1`` .. ``triangle:15``) at ``b_trials`` starts each. A part *converges* when its entropy
reaches zero at some tilt (the report's B row counts reaching and ending apart; both are kept).
The combined criterion ``D_AB = D + |b / 15 - 10 / 15|`` adds the distance of the converging
parts ``b`` from the paper's 10 of 15 (fixed before any B result existed, 2026-11-26).

Small M makes zero entropy easier to reach (fewer starts to gather into one cell); every candidate
and every map is run at the same M and seeds, so the comparisons are like for like, but the
absolute shares are not the paper's M = 1,000 (C) or 10,000 (A).

Run in parts (each a separate heavy job), then write the report::

    python -m analysis.friction_study c_amplitude c_mean search b_search --out DIR
    python -m analysis.friction_study report --out DIR
"""
from __future__ import annotations

import argparse
import json
import os
from dataclasses import asdict, dataclass, field

import numpy as np

__all__ = ["FrictionStudySettings", "FrictionStudyResult", "c_reading", "mean_maps", "physics_search",
           "run_friction_study",
           "criterion", "study_from_parts", "PAPER", "b_search", "combined_criterion", "B_SEQUENCE", "B_PARTS"]

#: the paper's numbers (Mannam et al.): A 29 of 43, B 10 of 15, C 10 of 13 / 0 of 3 / 0 of 4.
PAPER = {"A_converged": 29, "A_sequences": 43, "B_converged": 10, "B_parts": 15,
         "C": {"low": (10, 13), "medium": (0, 3), "high": (0, 4)}}
#: experiment A's best sequence of the full report (reports/full/index.md, "Best sequence"), the
#: sequence the paper's C replays (its green line).
REPORT_BEST_SEQUENCE = ("E,S,W,W,W,NW,N,SW,NE,W,W,S,NW,SW,N,E,SW,NW,W,E,SW,NE,SE,N,N,NW,E,N,SW,NE,NE,N,NE,E,W,"
                        "NE,SE,SE,NE,W,E,N,E,SW,SE,E,SW,NW,SE,SW")
#: experiment A's best sequence of the committed report (reports/full/index.md, 9549441's run), which
#: its B replays on the parts; the B search replays the same sequence under every candidate.
B_SEQUENCE = ("S,NW,SE,N,NW,NE,NE,NE,N,SE,SW,SW,E,W,SW,S,W,W,N,E,SW,NW,NW,N,W,SE,SE,E,NE,S,W,E,N,E,SE,W,SE,NE,"
              "W,N,SW,E,N,E,E,SE,E,W,NW,SW")
#: the report's B parts (``ReproduceSettings.parts``)
B_PARTS = tuple(f"triangle:{i}" for i in range(1, 16))
#: the candidate physics of the search: (label, friction spec, tilt time s).
CANDIDATES = (("today's default", "0.3", 0.0),
              ("Simscape defaults 0.5/0.3", "0.5/0.3", 0.0),
              ("handbook Al on steel 0.61/0.47", "0.61/0.47", 0.0),
              ("mu 0.2", "0.2", 0.0),
              ("Simscape defaults, 0.5 s tilt", "0.5/0.3", 0.5),
              ("mu 0.15", "0.15", 0.0))


@dataclass(frozen=True)
class FrictionStudySettings:
    """What the study runs (every random choice from the seeds named here).

    Attributes
    ----------
    sequence : str
        The sequence of C (A's best, comma-separated).
    trials : int
        Direct-simulation starts per map (C) and per sequence (search).
    seed : int
        Seed of the start poses and of the search's random sequences.
    amplitude_maps : tuple
        ``(level, count)``: today's maps ``map:LEVEL:1..count`` at mean 0.3.
    mean_maps : int
        How many maps of differing mean (the paper: 20) ...
    mean_range : (float, float)
        ... with means drawn uniformly from this range ...
    mean_seed : int
        ... by ``numpy.random.default_rng(mean_seed)``; map k is ``map:low:k+1:MEAN``.
    groups : (int, int, int)
        The paper's grouping by mean: the lowest 13 are low, the next 3 medium, the top 4 high.
    search_sequences : int
        K random 50-tilt sequences per candidate physics.
    candidates : tuple
        ``(label, friction, tilt_time_s)`` of the search.
    b_parts, b_sequence, b_trials
        The B search: the parts, the sequence replayed on them, and the starts per part.
    """

    sequence: str = REPORT_BEST_SEQUENCE
    trials: int = 200
    seed: int = 0
    amplitude_maps: tuple = (("low", 4), ("medium", 3), ("high", 4))
    mean_maps: int = 20
    mean_range: tuple = (0.2, 0.5)
    mean_seed: int = 4040
    groups: tuple = (13, 3, 4)
    search_sequences: int = 6
    search_trials: int = 100
    candidates: tuple = CANDIDATES
    b_parts: tuple = B_PARTS
    b_sequence: str = B_SEQUENCE
    b_trials: int = 100
    workers: int | None = None


def _direct(spec: str, sequence, trials: int, seed: int, workers, tilt_time_s: float = 0.0,
            shape: str = "allen-key") -> dict:
    from analysis.montecarlo import run_direct
    from transition_builder.scene import scene_from_options

    scene = scene_from_options(shape, spec, tilt_time_s=tilt_time_s)
    res = run_direct(scene, sequence, trials, seed=seed, workers=workers)
    h = [float(v) for v in res.entropy_bits]
    return {"friction": spec, "tilt_time_s": tilt_time_s, "entropy_bits": h, "trials": int(trials),
            "faults": dict(res.faults), "reaches_zero": any(v == 0.0 for v in h), "ends_zero": h[-1] == 0.0}


def mean_maps(s: FrictionStudySettings) -> list[tuple[str, float]]:
    """The maps of differing mean: ``[(spec, mean)]`` in map order (``map:low:k:MEAN``)."""
    rng = np.random.default_rng(s.mean_seed)
    lo, hi = s.mean_range
    means = np.round(rng.uniform(lo, hi, s.mean_maps), 3)
    return [(f"map:low:{k + 1}:{m:g}", float(m)) for k, m in enumerate(means)]


def c_reading(s: FrictionStudySettings, which: str, progress=print, on_item=None, done=None) -> dict:
    """One reading of C (``"amplitude"`` or ``"mean"``): every map's entropy curve along the sequence.
    ``on_item(results_so_far)`` is called after every map (to save partial results); ``done`` holds the
    maps of an earlier, interrupted run of the same reading, kept where their trials and seed match
    (each map's run is seeded on its own, so a resumed reading equals an uninterrupted one)."""
    if which == "amplitude":
        maps = [(f"map:{lv}:{k}", 0.3, lv) for lv, n in s.amplitude_maps for k in range(1, n + 1)]
    elif which == "mean":
        specs = mean_maps(s)
        order = np.argsort([m for _, m in specs], kind="stable")
        label = np.empty(len(specs), dtype=object)
        bounds = np.cumsum(s.groups)
        for rank, i in enumerate(order):
            label[i] = "low" if rank < bounds[0] else ("medium" if rank < bounds[1] else "high")
        maps = [(spec, m, str(label[i])) for i, (spec, m) in enumerate(specs)]
    else:
        raise ValueError(f"unknown reading {which!r}: amplitude or mean")
    out = {}
    for spec, mean, group in maps:
        old = (done or {}).get(spec)
        if old is not None and old.get("trials") == s.trials and old.get("seed", s.seed) == s.seed:
            out[spec] = old
            continue
        progress(f"C ({which}): {spec}, {s.trials} trials")
        out[spec] = dict(_direct(spec, s.sequence, s.trials, s.seed, s.workers), mean=mean, group=group, seed=s.seed)
        if on_item:
            on_item(out)
    return out


def criterion(share: float, h20: float, h0: float) -> float:
    """``|share - 29/43| + h20 / h0``: the search's distance from the paper's A (0 is the paper)."""
    return abs(share - PAPER["A_converged"] / PAPER["A_sequences"]) + h20 / h0


def physics_search(s: FrictionStudySettings, progress=print, on_item=None) -> dict:
    """Every candidate physics on K random 50-tilt sequences: share reaching zero, mean entropy at 20, D.
    ``on_item(results_so_far)`` is called after every candidate."""
    from analysis.sequences import random_sequences_for
    from transition_builder.scene import ACTIONS

    seqs = random_sequences_for(8, s.search_sequences, 50, s.seed)
    out = {}
    for label, spec, tilt_time in s.candidates:
        progress(f"search: {label} ({spec}, tilt time {tilt_time:g} s)")
        runs = [_direct(spec, [ACTIONS[a] for a in q], s.search_trials, s.seed, s.workers, tilt_time) for q in seqs]
        curves = np.array([r["entropy_bits"] for r in runs])
        share = float(np.mean([r["reaches_zero"] for r in runs]))
        h20, h0 = float(curves[:, 20].mean()), float(curves[:, 0].mean())
        out[label] = {"friction": spec, "tilt_time_s": tilt_time, "share_reaching_zero": share,
                      "share_ending_zero": float(np.mean([r["ends_zero"] for r in runs])),
                      "mean_entropy_20": h20, "mean_entropy_50": float(curves[:, 50].mean()), "entropy_0": h0,
                      "D": criterion(share, h20, h0), "sequences": len(runs), "trials": s.search_trials}
        if on_item:
            on_item(out)
    return out


def b_criterion(converged: int, parts: int) -> float:
    """``|b / parts - 10 / 15|``: the distance of the B parts that converge from the paper's 10 of 15."""
    return abs(converged / parts - PAPER["B_converged"] / PAPER["B_parts"])


def b_search(s: FrictionStudySettings, progress=print, on_item=None, done=None, a_search: dict | None = None) -> dict:
    """Every candidate physics on B: the B sequence replayed on each B part at ``b_trials`` starts.
    ``on_item(results_so_far)`` is called after every part (to save partial results); ``done`` holds
    an earlier, interrupted run's results, whose parts are kept where their trials, seed and sequence
    match (each part's run is seeded on its own, so a resumed search equals an uninterrupted one).
    With the A search's results (``a_search``) the candidates run closest to the paper's A first
    (by D), so that an interrupted search has measured the likeliest physics; candidates with a tilt
    time run last (their tilts cost about three times as much)."""
    # an interrupted run's candidates stay in the saved results until their turn comes
    out = {label: old for label, old in (done or {}).items() if label in {c[0] for c in s.candidates}}
    order = sorted(s.candidates, key=lambda c: (c[2] > 0, (a_search or {}).get(c[0], {}).get("D", float("inf"))))
    for label, spec, tilt_time in order:
        old = ((done or {}).get(label) or {}).get("parts", {})
        parts = {}
        for part in s.b_parts:
            kept = old.get(part)
            if kept is not None and (kept.get("trials"), kept.get("seed"), kept.get("sequence")) == (
                    s.b_trials, s.seed, s.b_sequence):
                parts[part] = kept
                continue
            progress(f"B search: {label} ({spec}, tilt time {tilt_time:g} s): {part}, {s.b_trials} trials")
            r = _direct(spec, s.b_sequence, s.b_trials, s.seed, s.workers, tilt_time, shape=part)
            parts[part] = dict(r, seed=s.seed, sequence=s.b_sequence)
            out[label] = _b_summary(spec, tilt_time, parts, len(s.b_parts))
            if on_item:
                on_item(out)
        out[label] = _b_summary(spec, tilt_time, parts, len(s.b_parts))
    return out


def combined_criterion(a: dict | None, b: dict | None) -> float | None:
    """``D_AB = D + B distance`` of one candidate from its A search entry ``a`` and B search entry
    ``b`` (None when either was not measured)."""
    return None if a is None or b is None else a["D"] + b["B_distance"]


def _b_summary(spec, tilt_time, parts: dict, planned: int) -> dict:
    reached = sum(p["reaches_zero"] for p in parts.values())
    return {"friction": spec, "tilt_time_s": tilt_time, "parts": parts, "measured": len(parts), "planned": planned,
            "reaches_zero": int(reached), "ends_zero": int(sum(p["ends_zero"] for p in parts.values())),
            "mean_entropy_50": float(np.mean([p["entropy_bits"][-1] for p in parts.values()])),
            "faults": int(sum(sum(p["faults"].values()) for p in parts.values())),
            "B_distance": b_criterion(int(reached), len(parts))}


def _groups(maps: dict) -> dict:
    g = {}
    for level in ("low", "medium", "high"):
        group = [m for m in maps.values() if m["group"] == level]
        if group:
            g[level] = {"maps": len(group), "ends_zero": sum(m["ends_zero"] for m in group),
                        "reaches_zero": sum(m["reaches_zero"] for m in group),
                        "mean_coefficients": [m["mean"] for m in group],
                        "mean_entropy": np.mean([m["entropy_bits"] for m in group], axis=0).tolist()}
    return g


def study_physics() -> dict:
    """The physics the study simulates (the default simulator settings, engine included): a report cites
    the study's figures only when they come from the report's own physics."""
    from transition_builder.sim_settings import SimSettings
    return SimSettings().to_dict()


@dataclass(frozen=True)
class FrictionStudyResult:
    """The study's measurements: C's readings (per map and grouped) and the physics search."""

    settings: dict
    c_amplitude: dict = field(default_factory=dict)
    c_mean: dict = field(default_factory=dict)
    search: dict = field(default_factory=dict)
    b_search: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        out = asdict(self)
        out["c_groups"] = {"amplitude": _groups(self.c_amplitude), "mean": _groups(self.c_mean)}
        out["paper"] = PAPER
        out["physics"] = study_physics()
        return out

    def markdown(self) -> str:
        """The study's section: C's readings beside the paper, and the search's table."""
        lines = ["## Experiment C and the floor's friction (issue 40)", ""]
        s = self.settings
        lines += [f"Direct simulation along A's best sequence, M = {s['trials']} starts per map, seed {s['seed']} "
                  "(`python -m analysis.friction_study`). A map converges when the entropy on the report grid is "
                  "zero at tilt 50 (reached: at any tilt).", "",
                  "| reading | low | medium | high |", "|---|---|---|---|",
                  "| the paper (20 maps grouped by mean friction) | 10 of 13 | 0 of 3 | 0 of 4 |"]
        planned = {"amplitude": dict(s.get("amplitude_maps", ())),
                   "mean": dict(zip(("low", "medium", "high"), s.get("groups", ())))}
        for which, name, maps in (("amplitude", "today's maps: mean 0.3, growing amplitude", self.c_amplitude),
                                  ("mean", "20 maps of differing mean (low amplitude), grouped by mean as the "
                                   "paper did", self.c_mean)):
            g = _groups(maps)
            if g:
                cells = []
                for lv in ("low", "medium", "high"):
                    x = g.get(lv)
                    n = planned[which].get(lv)
                    of = "" if n is None or n == (x or {}).get("maps") else f" measured of {n}"
                    cells.append(f"- (0{of})" if x is None else
                                 f"{x['ends_zero']} of {x['maps']}{of} (reached {x['reaches_zero']}); mean mu "
                                 f"{min(x['mean_coefficients']):.2f}-{max(x['mean_coefficients']):.2f}")
                lines.append(f"| {name} | " + " | ".join(cells) + " |")
        if self.c_mean:
            lines += ["", "Per map of differing mean (sorted by mean): mean coefficient, converges?, entropy at 50:", ""]
            rows = sorted(self.c_mean.items(), key=lambda kv: kv[1]["mean"])
            lines.append(", ".join(f"{m['mean']:.3f} {'yes' if m['ends_zero'] else 'no'} "
                                   f"({m['entropy_bits'][-1]:.2f})" for _, m in rows) + ".")
        if self.search:
            h = PAPER["A_converged"] / PAPER["A_sequences"]
            lines += ["", f"**Which physics reproduces A.** Criterion D = |share - 29/43| + H20 / H0 (share of random "
                      f"50-tilt sequences whose entropy reaches zero, paper {h:.3f}; mean entropy at tilt 20 over the "
                      f"starting entropy, paper about 0); {s['search_sequences']} of A's random sequences, M = "
                      f"{s['search_trials']} each. Lower is better.", "",
                      "| physics | friction | tilt time (s) | share reaching zero | mean H at 20 | at 50 | D |",
                      "|---|---|---|---|---|---|---|"]
            for label, r in sorted(self.search.items(), key=lambda kv: kv[1]["D"]):
                lines.append(f"| {label} | `{r['friction']}` | {r['tilt_time_s']:g} | {r['share_reaching_zero']:.2f} | "
                             f"{r['mean_entropy_20']:.2f} | {r['mean_entropy_50']:.2f} | {r['D']:.2f} |")
        if self.b_search:
            lines += self._b_lines()
        return "\n".join(lines) + "\n"

    def _b_lines(self) -> list[str]:
        s = self.settings
        lines = ["", f"**Which physics reproduces B.** A's best sequence of the report replayed on the "
                 f"{len(s.get('b_parts', B_PARTS))} B parts, M = {s.get('b_trials')} starts each (the paper: 10 of 15 "
                 "parts converge). B distance = |b / 15 - 10 / 15| (b: parts whose entropy reaches zero); D_AB = D + "
                 "B distance, with D the A criterion above. Lower is better.", "",
                 "| physics | friction | tilt time (s) | parts reaching zero | ending at zero | mean H at 50 | "
                 "faults | B distance | D (A) | D_AB |", "|---|---|---|---|---|---|---|---|---|---|"]

        def d_ab(item):
            total = combined_criterion(self.search.get(item[0]), item[1])
            return (total is None, item[1]["B_distance"] if total is None else total)
        for label, r in sorted(self.b_search.items(), key=d_ab):
            a, total = self.search.get(label), combined_criterion(self.search.get(label), r)
            a_text, ab_text = ("-", "-") if a is None else (f"{a['D']:.2f}", f"{total:.2f}")
            part = "" if r["measured"] == r["planned"] else f" (measured {r['measured']} of {r['planned']})"
            lines.append(f"| {label} | `{r['friction']}` | {r['tilt_time_s']:g} | {r['reaches_zero']} of "
                         f"{r['measured']}{part} | {r['ends_zero']} | {r['mean_entropy_50']:.2f} | {r['faults']} | "
                         f"{r['B_distance']:.2f} | {a_text} | {ab_text} |")
        return lines

    def figures(self, out_dir: str) -> list[str]:
        """``fig_friction_c.png``: mean entropy per group of each reading. Returns the files written."""
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        readings = [(n, _groups(m)) for n, m in (("today's maps (amplitude)", self.c_amplitude),
                                                 ("maps of differing mean", self.c_mean)) if m]
        if not readings:
            return []
        fig, axes = plt.subplots(1, len(readings), figsize=(5 * len(readings), 3.5), squeeze=False)
        for ax, (name, g) in zip(axes[0], readings):
            for lv, x in g.items():
                ax.plot(x["mean_entropy"], label=f"{lv} ({x['ends_zero']}/{x['maps']})")
            ax.set_title(name)
            ax.set_xlabel("tilt")
            ax.set_ylabel("mean entropy (bits)")
            ax.legend()
        path = os.path.join(out_dir, "fig_friction_c.png")
        fig.tight_layout()
        fig.savefig(path + ".tmp.png", dpi=100)
        plt.close(fig)
        os.replace(path + ".tmp.png", path)
        return [path]


def run_friction_study(settings: FrictionStudySettings | None = None,
                       parts=("c_amplitude", "c_mean", "search", "b_search"),
                       progress=print) -> FrictionStudyResult:
    """Run the study in one call (the entry a report section registers): the named parts of
    ``settings`` (default :class:`FrictionStudySettings`), as :func:`main` runs them one by one."""
    s = settings or FrictionStudySettings()
    out = {}
    for part in parts:
        if part.startswith("c_"):
            out[part] = c_reading(s, part[2:], progress)
        else:
            out[part] = (b_search if part == "b_search" else physics_search)(s, progress)
    return FrictionStudyResult(settings=asdict(s), **out)


def study_from_parts(out_dir: str, settings: FrictionStudySettings) -> FrictionStudyResult:
    """The result assembled from the parts' JSON files in ``out_dir`` (missing parts stay empty)."""
    parts = {}
    for name in ("c_amplitude", "c_mean", "search", "b_search"):
        path = os.path.join(out_dir, f"{name}.json")
        if os.path.exists(path):
            with open(path) as f:
                parts[name] = json.load(f)
    return FrictionStudyResult(settings=asdict(settings), **parts)


def main(argv=None) -> int:
    from kruskal_markov.model import atomic_write_text

    p = argparse.ArgumentParser(prog="python -m analysis.friction_study", description=__doc__.split("\n")[0])
    p.add_argument("parts", nargs="+", choices=["c_amplitude", "c_mean", "search", "b_search", "report"])
    p.add_argument("--out", required=True)
    p.add_argument("--trials", type=int, default=200)
    p.add_argument("--search-trials", type=int, default=100)
    p.add_argument("--search-sequences", type=int, default=6)
    p.add_argument("--b-trials", type=int, default=100)
    p.add_argument("--workers", type=int, default=None)
    a = p.parse_args(argv)
    s = FrictionStudySettings(trials=a.trials, search_trials=a.search_trials, search_sequences=a.search_sequences,
                              b_trials=a.b_trials, workers=a.workers)
    os.makedirs(a.out, exist_ok=True)
    for part in a.parts:
        if part == "report":
            res = study_from_parts(a.out, s)
            atomic_write_text(os.path.join(a.out, "friction_study.json"), json.dumps(res.to_dict(), indent=1))
            atomic_write_text(os.path.join(a.out, "friction_study.md"), res.markdown())
            res.figures(a.out)
            print(res.markdown())
            continue
        path = os.path.join(a.out, f"{part}.json")

        def save(data, path=path):
            atomic_write_text(path, json.dumps(data, indent=1))
        done = None
        if part != "search" and os.path.exists(path):
            with open(path) as f:
                done = json.load(f)
        if part.startswith("c_"):
            save(c_reading(s, part[2:], on_item=save, done=done))
        elif part == "b_search":
            a_search = None
            if os.path.exists(os.path.join(a.out, "search.json")):
                with open(os.path.join(a.out, "search.json")) as f:
                    a_search = json.load(f)
            save(b_search(s, on_item=save, done=done, a_search=a_search))
        else:
            save(physics_search(s, on_item=save))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

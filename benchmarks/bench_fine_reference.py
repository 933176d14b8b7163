"""Both key models against a reference neither was built from (issue 44, sixth session): today's
default simulator at a quarter of the step (docs/builder.md, "Sixth session").

The models (``KRUSKAL_BENCH_LONG_SAVE``/LABEL.npz): ``default`` (today's default key model) and a
candidate's (``KRUSKAL_BENCH_FINE_CANDIDATE``, default ``needed-floating-stick``). The references
are direct simulations (:func:`transition_builder.tilting.run_direct`) of the validation's random
sequences (:func:`analysis.validate.validate_model`'s, 30 tilts, the same trial seeds), one sequence
per call, each saved to ``KRUSKAL_BENCH_FINE_DIR`` as it ends (so a killed job loses one sequence
at most; a saved one is never run again).

Parts (``KRUSKAL_BENCH_FINE_PART``, comma-separated):

- ``cpu``: CPU seconds per tilt of a direct simulation at the default step and at a quarter of it
  (``KRUSKAL_BENCH_FINE_CPU_TRIALS`` (20) trials of one random sequence of the dev seed 1, in this
  process): what M fits a lock job.
- ``ref:SEED:I`` / ``step:SEED:I`` / ``own:SEED:I``: sequence ``I`` (0, 1, 2) of ``SEED``, M =
  ``KRUSKAL_BENCH_LONG_TRIALS`` (1,000) trials, under today's default simulator at a quarter of the
  step (``ref``), at its own step (``step``), or under the candidate's simulator at a quarter of
  the step (``own``).
- ``compare:SEED``: both models against every saved reference of ``SEED`` (mean error, worst step,
  final TV distance, the reference's sampling noise), and the default simulator at its own step
  against the quarter-step reference (the simulator's spread: same starts, same trial seeds).

Run: ``KRUSKAL_BENCH_FINE_PART=ref:8231:0 KRUSKAL_BENCH_LONG_SAVE=MODELS KRUSKAL_BENCH_FINE_DIR=OUT
python -m benchmarks fine_reference``.
"""
from __future__ import annotations

import json
import os
import pathlib
import pickle
import time

import numpy as np

from benchmarks.bench_part_links import VARIANTS

#: the quarter step of the reference
REFINE = 4
SEQUENCES = 3
LENGTH = 30
#: today's default simulator's settings (what ``default`` means in a scene of another physics)
DEFAULT = {"contact_pairs": "all", "long_steps": "free", "part_links": "per-part"}
KINDS = ("ref", "step", "own")


def _models() -> dict:
    from kruskal_markov.model import TransitionModel
    save = os.environ["KRUSKAL_BENCH_LONG_SAVE"]
    cand = os.environ.get("KRUSKAL_BENCH_FINE_CANDIDATE", "needed-floating-stick")
    return {label: TransitionModel.load(os.path.join(save, f"{label}.npz")) for label in ("default", cand)}


def _scene(model, kind: str):
    """The scene a reference of ``kind`` simulates: the model's tray, part and friction under
    today's default simulator (``ref``, ``step``) or the candidate's (``own``), at a quarter of
    the step (``ref``, ``own``) or at the step (``step``)."""
    from analysis.validate import model_scene
    cand = VARIANTS[os.environ.get("KRUSKAL_BENCH_FINE_CANDIDATE", "needed-floating-stick")]
    sc = model_scene(model).with_settings(**(cand if kind == "own" else DEFAULT))
    if kind != "step":
        sc = sc.with_settings(**sc.settings.finer_step(REFINE))
    return sc


def _path(kind: str, seed: int, i: int, trials: int) -> pathlib.Path:
    return pathlib.Path(os.environ["KRUSKAL_BENCH_FINE_DIR"]) / f"{kind}-{seed}-{i}-M{trials}.pkl"


def simulate_one(kind: str, seed: int, i: int, trials: int) -> None:
    """Direct simulation of sequence ``i`` of ``seed`` (``kind``: ``ref``, ``step`` or ``own``),
    saved atomically; skipped when saved already."""
    from analysis.validate import model_grid, random_sequences_for, reference_seed
    from transition_builder.tilting import run_direct
    out = _path(kind, seed, i, trials)
    if out.exists():
        print(f"{out.name}: saved already", flush=True)
        return
    model = _models()["default"]
    seq = random_sequences_for(model.n_actions, SEQUENCES, LENGTH, seed)[i]
    sc = _scene(model, kind)
    t = time.process_time()
    r = run_direct(sc, seq, trials, seed=reference_seed(seed, i), workers=1, grid=model_grid(model),
                   noise=model.metadata.get("noise", "none"))
    cpu = time.process_time() - t
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp")
    tmp.write_bytes(pickle.dumps({"result": r, "cpu_s": cpu, "settings": sc.settings.to_dict()}))
    tmp.replace(out)
    print(f"{out.name}: {trials} trials x {LENGTH} tilts, {cpu:.0f} CPU s "
          f"({1e3 * cpu / (trials * LENGTH):.2f} ms per tilt), faults {r.faults}", flush=True)


def _load(kind: str, seed: int, i: int, trials: int):
    p = _path(kind, seed, i, trials)
    return pickle.loads(p.read_bytes())["result"] if p.exists() else None


def compare(seed: int, trials: int) -> dict:
    """Both models against the saved quarter-step references of ``seed`` (and against the
    step's, and the step's spread), over the sequences saved for every kind compared."""
    from analysis.validate import validate_model
    models = _models()
    out = {}
    for kind in ("ref", "step", "own"):
        n = 0
        while n < SEQUENCES and _path(kind, seed, n, trials).exists():
            n += 1
        if not n:
            continue
        refs = {reference_i: _load(kind, seed, reference_i, trials) for reference_i in range(n)}

        def simulate(sc, sq, m, sd, nz, refs=refs):
            from analysis.validate import reference_seed
            for j, r in refs.items():
                if reference_seed(seed, j) == sd and list(r.sequence) == [int(a) for a in sq]:
                    assert m == trials
                    return r
            raise KeyError(sd)

        for label, model in models.items():
            if kind == "own" and label == "default":
                continue
            v = validate_model(model, sequences=n, trials=trials, seed=seed, length=LENGTH, bands=0,
                               simulate=simulate)
            row = {k: round(v[k], 4) for k in ("mean_abs_error_bits", "max_abs_error_bits", "final_tv_distance",
                                               "reference_noise_bits")}
            row["per_sequence_mean"] = [round(s["mean_abs_error_bits"], 4) for s in v["per_sequence"]]
            out[f"{label} vs {kind}"] = row
            print(f"seed {seed}, M = {trials}, {n} sequences, {label} against {kind}: " + json.dumps(row), flush=True)
    n = 0
    while n < SEQUENCES and _path("ref", seed, n, trials).exists() and _path("step", seed, n, trials).exists():
        n += 1
    if n:
        d = np.concatenate([np.abs(_load("step", seed, i, trials).entropy_bits
                                   - _load("ref", seed, i, trials).entropy_bits)[1:] for i in range(n)])
        out["spread: step vs ref"] = {"mean_abs_diff_bits": round(float(d.mean()), 4),
                                      "max_abs_diff_bits": round(float(d.max()), 4), "sequences": n}
        print(f"seed {seed}, M = {trials}, {n} sequences, the default simulator at its step against a quarter "
              f"of it (same trials): " + json.dumps(out["spread: step vs ref"]), flush=True)
    return out


def cpu(trials: int) -> dict:
    """CPU per tilt of direct simulation at the step and at a quarter of it (dev seed 1)."""
    from analysis.validate import random_sequences_for
    from transition_builder.tilting import run_direct
    model = _models()["default"]
    seq = random_sequences_for(model.n_actions, 1, LENGTH, 1)[0]
    out = {}
    for kind in ("step", "ref", "step", "ref"):
        sc = _scene(model, kind)
        t = time.process_time()
        run_direct(sc, seq, trials, seed=1, workers=1)
        ms = 1e3 * (time.process_time() - t) / (trials * LENGTH)
        out.setdefault(kind, []).append(ms)
        print(f"{kind}: {ms:.2f} ms per tilt", flush=True)
    return out


def main():
    trials = int(os.environ.get("KRUSKAL_BENCH_LONG_TRIALS", "1000"))
    for part in os.environ.get("KRUSKAL_BENCH_FINE_PART", "cpu").split(","):
        kind, *rest = part.split(":")
        if kind == "cpu":
            cpu(int(os.environ.get("KRUSKAL_BENCH_FINE_CPU_TRIALS", "20")))
        elif kind in KINDS and len(rest) == 2:
            simulate_one(kind, int(rest[0]), int(rest[1]), trials)
        elif kind == "compare" and len(rest) == 1:
            compare(int(rest[0]), trials)
        else:
            raise SystemExit(f"unknown part {part!r}: cpu, ref:SEED:I, step:SEED:I, own:SEED:I, compare:SEED")


if __name__ == "__main__":
    main()

"""A lighter multibody for the part (issue 44, fourth round): ``SimSettings.part_links`` against
today's chain of one fixed link per convex part (docs/builder.md, "A lighter multibody").

The variants (:data:`VARIANTS`, SimSettings changes): today's default, ``contact_pairs=needed``
alone, the convex parts as one compound link (``compound``) with all pairs and with ``needed``, and
the compound as the yaw link's own shape with the support sphere a fixed child (``yaw-compound``,
with ``needed``), and the part as the multibody's free base with no slide or hinge links
(``floating``; with ``needed``, and with ``needed`` and ``long_steps=free+stick``).

Parts (``KRUSKAL_BENCH_LINKS_PART``, comma-separated; default ``cpu``):

- ``cpu``: :func:`benchmarks.bench_long_steps.cpu_side_by_side` over the variants named in
  ``KRUSKAL_BENCH_LINKS_CPU`` (default: the first five; the first is the reference): CPU seconds
  per tilt side by side in alternating rounds (``KRUSKAL_BENCH_LONG_ROUNDS``, 2), on
  ``KRUSKAL_BENCH_LONG_STARTS`` (300) uniform allen-key starts of seed 31 tilted E and NE and on
  their rest poses under E tilted N, NE, W and SW; landings within 1 mm / 1 degree of the default's;
  a small serial build (8 mm / 8 deg, 50 starts): tilts per CPU second.
- ``links``: :func:`extra_links`, the CPU of a rest-pose tilt with 0, 2, 4 or 8 extra fixed,
  shapeless links appended to the chain (what one link of the chain costs).
- ``judges:LABEL``: the free-sliding judges of variant ``LABEL`` (1/16 of the step) against
  :data:`~transition_builder.judges.JUDGE_TARGETS`.
- ``build:LABEL``: the key's default model with variant ``LABEL`` built from scratch on 2 workers;
  saved to ``KRUSKAL_BENCH_LONG_SAVE``/LABEL.npz when that directory is set.
- ``validate:LABEL``: the held-out validation (seed :data:`VALIDATION_SEED`, 3 sequences x 30
  tilts, ``KRUSKAL_BENCH_LONG_TRIALS`` trials) of the saved ``default`` and ``LABEL`` models against
  one direct simulation under the default simulator.
- ``validate-own:LABEL``: the same validation of the saved ``LABEL`` model against a direct
  simulation under its own simulator settings (the builder's error apart from the physics change).

The step convergence is ``python -m benchmarks contact`` with
``KRUSKAL_BENCH_CONTACT_MODELS=coulomb,coulomb-needed,coulomb-needed-compound``.
Run: ``KRUSKAL_BENCH_LINKS_PART=cpu python -m benchmarks part_links``.
"""
from __future__ import annotations

import os

VARIANTS = {"default": {},
            "needed": {"contact_pairs": "needed"},
            "compound": {"part_links": "compound"},
            "needed-compound": {"contact_pairs": "needed", "part_links": "compound"},
            "needed-yaw": {"contact_pairs": "needed", "part_links": "yaw-compound"},
            "floating": {"part_links": "floating"},
            "needed-floating": {"contact_pairs": "needed", "part_links": "floating"},
            "needed-floating-stick": {"contact_pairs": "needed", "part_links": "floating", "long_steps": "free+stick"}}
#: the held-out seed of this round's validation (named in docs/builder.md before its first run)
VALIDATION_SEED = 7411


def extra_links(counts=(0, 2, 4, 8), rounds: int = 2, n_starts: int = 100) -> dict:
    """What one more link costs: CPU per rest-pose tilt (``contact_pairs=needed``; the rest poses
    of ``n_starts`` uniform starts of seed 31 under E, tilted N, NE, W and SW) with ``K`` extra fixed,
    shapeless links of negligible mass appended to the part's chain (``pybullet.createMultiBody``
    wrapped for the run), alternating, ``rounds`` times."""
    import time

    import numpy as np
    import pybullet as pb

    from transition_builder.sampling import sample_start_poses
    from transition_builder.scene import scene_from_options
    from transition_builder.sim import TraySimulator
    orig, extra = pb.createMultiBody, [0]

    def more_links(*a, **k):
        n = extra[0]
        if n and len(k.get("linkMasses", [])) >= 5:
            for key, val in (("linkMasses", k["linkMasses"][0]), ("linkCollisionShapeIndices", -1),
                             ("linkVisualShapeIndices", -1), ("linkPositions", [0, 0, 0]),
                             ("linkOrientations", [0, 0, 0, 1]), ("linkInertialFramePositions", [0, 0, 0]),
                             ("linkInertialFrameOrientations", [0, 0, 0, 1]), ("linkParentIndices", 4),
                             ("linkJointTypes", pb.JOINT_FIXED), ("linkJointAxis", [0, 0, 1])):
                k[key] = list(k[key]) + [val] * n
        return orig(*a, **k)

    sc = scene_from_options("allen-key", contact_pairs="needed")
    starts = sample_start_poses(sc.shape, 200.0, 200.0, n_starts, np.random.default_rng(31))
    with TraySimulator(sc) as sim:
        rest, st = sim.tilt(starts, "E")
    rest = rest[st == 0]
    out = {k: [] for k in counts}
    pb.createMultiBody = more_links
    try:
        for rnd in range(rounds):
            for k in counts:
                extra[0] = k
                with TraySimulator(sc) as sim:
                    sim.prepare()
                    t = time.process_time()
                    n = sum(len(sim.tilt(rest, a)[0]) for a in ("N", "NE", "W", "SW"))
                    out[k].append(1e3 * (time.process_time() - t) / n)
                print(f"round {rnd + 1}, {k} extra fixed links: {out[k][-1]:.2f} ms per rest-pose tilt", flush=True)
    finally:
        pb.createMultiBody = orig
    return {k: float(np.mean(v)) for k, v in out.items()}


def main():
    from benchmarks import bench_long_steps as ls
    for part in os.environ.get("KRUSKAL_BENCH_LINKS_PART", "cpu").split(","):
        kind, _, label = part.partition(":")
        if label and label not in VARIANTS:
            raise SystemExit(f"unknown variant {label!r}: {', '.join(VARIANTS)}")
        if kind == "cpu":
            chosen = os.environ.get("KRUSKAL_BENCH_LINKS_CPU", "default,needed,compound,needed-compound,needed-yaw")
            ls.cpu_side_by_side({k: VARIANTS[k] for k in chosen.split(",")})
        elif kind == "links":
            print("extra links: ms per rest-pose tilt " + str(extra_links()), flush=True)
        elif kind == "judges" and label:
            ls.judges(VARIANTS[label])
        elif kind == "build" and label:
            ls.build(label, settings=VARIANTS[label])
        elif kind == "validate-own" and label:
            ls.validate(int(os.environ.get("KRUSKAL_BENCH_LONG_TRIALS", "1000")), (label,), VALIDATION_SEED, own=True)
        elif kind == "validate" and label:
            ls.validate(int(os.environ.get("KRUSKAL_BENCH_LONG_TRIALS", "1000")), ("default", label), VALIDATION_SEED)
        else:
            raise SystemExit(f"unknown part {part!r}: cpu, links, judges:LABEL, build:LABEL, validate:LABEL, "
                             "validate-own:LABEL")


if __name__ == "__main__":
    main()

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
- ``judges:LABEL``: the free-sliding judges of variant ``LABEL`` (1/16 of the step) against
  :data:`~transition_builder.judges.JUDGE_TARGETS`.
- ``build:LABEL``: the key's default model with variant ``LABEL`` built from scratch on 2 workers;
  saved to ``KRUSKAL_BENCH_LONG_SAVE``/LABEL.npz when that directory is set.
- ``validate:LABEL``: the held-out validation (seed :data:`VALIDATION_SEED`, 3 sequences x 30
  tilts, ``KRUSKAL_BENCH_LONG_TRIALS`` trials) of the saved ``default`` and ``LABEL`` models against
  one direct simulation under the default simulator.

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


def main():
    from benchmarks import bench_long_steps as ls
    for part in os.environ.get("KRUSKAL_BENCH_LINKS_PART", "cpu").split(","):
        kind, _, label = part.partition(":")
        if label and label not in VARIANTS:
            raise SystemExit(f"unknown variant {label!r}: {', '.join(VARIANTS)}")
        if kind == "cpu":
            chosen = os.environ.get("KRUSKAL_BENCH_LINKS_CPU", "default,needed,compound,needed-compound,needed-yaw")
            ls.cpu_side_by_side({k: VARIANTS[k] for k in chosen.split(",")})
        elif kind == "judges" and label:
            ls.judges(VARIANTS[label])
        elif kind == "build" and label:
            ls.build(label, settings=VARIANTS[label])
        elif kind == "validate" and label:
            ls.validate(int(os.environ.get("KRUSKAL_BENCH_LONG_TRIALS", "1000")), ("default", label), VALIDATION_SEED)
        else:
            raise SystemExit(f"unknown part {part!r}: cpu, judges:LABEL, build:LABEL, validate:LABEL")


if __name__ == "__main__":
    main()

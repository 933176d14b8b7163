"""The report's sections, one module each: ``kruskal reproduce`` runs them in order.

Shaped like :mod:`analysis.commands`. :data:`EXPERIMENTS` is the ordered registry (the order of the
sections in ``index.md``); :func:`analysis.experiments.runner.run_experiments` runs every entry
with one :class:`~analysis.experiments.context.Context` and returns a
:class:`~analysis.experiments.runner.Report`, whose ``to_dict()`` is ``results.json``;
:mod:`analysis.report` writes ``index.md`` from the sections' markdown and figures.

Every section module has

- ``run(ctx) -> Result``: computes the section. ``ctx`` (:class:`~analysis.experiments.context.Context`)
  gives the settings (``ctx.settings``; a module reads its own view, a frozen ``Settings`` dataclass
  with ``Settings.from_settings(s)``), model builds (``ctx.build``, ``ctx.key_model``; cached and
  built once per run), direct simulation (``ctx.direct``), progress (``ctx.log``), workers, a memo
  of shared results (``ctx.memo``, ``ctx.ensemble``), another section's result
  (``ctx.result("A")``, run on demand) and named random streams (``ctx.seed("name")``,
  ``ctx.rng("name")``): a name gives the same draws wherever it is asked for and draws unrelated
  to every other name and every other ``--seed``;
- a frozen ``Result`` dataclass with ``to_dict()``: the top-level ``results.json`` entries the
  section adds (``{}`` for text-only sections);
- ``markdown(result) -> str``: the section's text ("" for none);
- ``figures(result, out) -> list[str]``: the figures written into the directory ``out``.

The paper's own numbers are :data:`analysis.experiments.paper.PAPER`; a model's paper-level
answers are one type, :class:`analysis.experiments.model_answers.ModelAnswers`.

How to add an experiment
------------------------
1. Write ``analysis/experiments/my_study.py`` with ``Settings`` (if it has any), ``Result``,
   ``run``, ``markdown`` and ``figures`` as above; draw every random number from a stream named
   after the study (``ctx.seed("my_study")``, ``ctx.seed(f"my_study:{i}")``), and list the name in
   :data:`analysis.streams.REPORT_STREAMS`, the table of every stream.
2. Add one line below: ``register("my_study", "analysis.experiments.my_study")``, where the section
   belongs in the report.
3. Its settings: add fields to :class:`analysis.reproduce.ReproduceSettings` (and to
   ``quick_settings`` when ``--quick`` should run it smaller) and read them in ``Settings.from_settings``.
"""
from __future__ import annotations

__all__ = ["EXPERIMENTS", "register"]

#: section name -> its module, in the order of the report.
EXPERIMENTS: dict[str, str] = {}


def register(name: str, module: str) -> None:
    """Add a section to :data:`EXPERIMENTS` (one line per section, below)."""
    EXPERIMENTS[name] = module


# --- the sections, in the order of the report ---------------------------------------------------------
register("key", "analysis.experiments.key")                    # the key's model against direct simulation
register("paper", "analysis.experiments.paper_table")          # the paper's numbers beside ours
register("A", "analysis.experiments.experiment_a")             # A: 43 random sequences (Fig. 3)
register("ensemble", "analysis.experiments.ensemble")          # A at scale: a million sequences
register("sync", "analysis.experiments.sync")                  # the optimal plan, expected random length
register("plans", "analysis.experiments.plans")                # plans for every target, replayed
register("contact", "analysis.experiments.contact")            # contact models and time steps
register("engines", "analysis.experiments.engines")            # engine against engine
register("sensitivity", "analysis.experiments.sensitivity")    # intervals and the settings' sensitivity
register("robot_log", "analysis.experiments.robot_log")        # a robot's log beside the model
register("tray_log", "analysis.experiments.tray_log")          # a tray's log: the friction fitted
register("B", "analysis.experiments.experiment_b")             # B: other parts (Fig. 4)
register("C", "analysis.experiments.experiment_c")             # C: friction maps (Fig. 6)
register("friction", "analysis.experiments.friction")          # C by mean, the physics of A (issue 40)
register("differences", "analysis.experiments.differences")    # how the differences arise, point by point
register("kits", "analysis.experiments.kits")                  # kits and trays: one plan for a kit, tray design

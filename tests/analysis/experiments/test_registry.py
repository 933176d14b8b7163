"""analysis.experiments: the registry, named random streams, the memo, and a new section added as
one module and one registry line (the full report on a small scene is test_reproduce.py)."""
from __future__ import annotations

import importlib
import json
import sys
import textwrap

import numpy as np
import pytest

from analysis.experiments import EXPERIMENTS, register
from analysis.experiments.context import Context, stream_seed
from analysis.reproduce import ReproduceSettings
from kruskal_markov.generators import random_model


@pytest.fixture(scope="module")
def model():
    return random_model(30, 4, 0.2, None, False, "uniform", seed=np.random.default_rng(3))


def test_every_section_has_the_interface():
    assert len(set(EXPERIMENTS.values())) == len(EXPERIMENTS)
    for name, path in EXPERIMENTS.items():
        module = importlib.import_module(path)
        for f in ("run", "markdown", "figures"):
            assert callable(getattr(module, f)), (name, f)
        assert hasattr(module.Result, "to_dict") and module.Result.__dataclass_params__.frozen, name


def test_named_streams_share_no_draws_across_names_or_seeds(model):
    """--seed 1's experiment A is not a prefix of --seed 0's large ensemble (it was with seed + k)."""
    s0, s1 = ReproduceSettings(seed=0, length=10), ReproduceSettings(seed=1, length=10)
    big0 = Context(s0).ensemble(model, 200, "ensemble")
    a1 = Context(s1).ensemble(model, 20, "A")
    a0 = Context(s0).ensemble(model, 20, "A")
    assert not np.array_equal(a1.sequences, big0.sequences[:20])
    assert not np.array_equal(a0.sequences, a1.sequences)
    assert not np.array_equal(a0.sequences, big0.sequences[:20])
    # one name, one stream: sections comparing models on "the same sequences" get them
    np.testing.assert_array_equal(Context(s0).ensemble(model, 20, "A").sequences, a0.sequences)
    assert len({stream_seed(seed, name) for seed in range(5) for name in ("A", "B", "ensemble", "C:map:1")}) == 20
    assert Context(s0).rng("A").integers(1 << 30) == Context(s0).rng("A").integers(1 << 30)


def test_memo_computes_once(model):
    ctx = Context(ReproduceSettings(length=5))
    calls = []
    assert ctx.memo("k", lambda: calls.append(1) or 7) == 7 and ctx.memo("k", lambda: calls.append(1) or 8) == 7
    assert calls == [1]
    first = ctx.ensemble(model, 10, "A")
    assert ctx.ensemble(model, 10, "A") is first
    kept = ctx.ensemble(model, 10, "A", keep_entropy=True)      # asked for more: recomputed, same draws
    assert kept.entropy is not None and np.array_equal(kept.sequences, first.sequences)


TRIVIAL = '''
"""A trivial section: the run's seed and one draw of its stream."""
import dataclasses


@dataclasses.dataclass(frozen=True)
class Result:
    draw: int

    def to_dict(self):
        return {"trivial": {"draw": self.draw}}


def run(ctx):
    return Result(int(ctx.rng("trivial").integers(1000)))


def markdown(r):
    return f"## Trivial\\n\\nThe draw was {r.draw}.\\n"


def figures(r, out):
    return []
'''


def test_a_new_section_is_one_module_and_one_registry_line(tmp_path, monkeypatch):
    from analysis.experiments.runner import run_experiments
    from analysis.report import write_report

    (tmp_path / "trivial_section.py").write_text(textwrap.dedent(TRIVIAL))
    monkeypatch.syspath_prepend(str(tmp_path))
    register("trivial", "trivial_section")
    try:
        report = run_experiments(ReproduceSettings(quick=True, seed=4), only=("trivial",))
        paths = write_report(report, str(tmp_path / "out"))
    finally:
        EXPERIMENTS.pop("trivial")
        sys.modules.pop("trivial_section", None)
    saved = json.loads((tmp_path / "out" / "results.json").read_text())
    draw = saved["trivial"]["draw"]
    assert draw == int(np.random.default_rng(stream_seed(4, "trivial")).integers(1000))
    assert saved["settings"]["seed"] == 4 and list(saved) == ["settings", "engine", "trivial", "seconds"]
    text = (tmp_path / "out" / "index.md").read_text()
    assert f"The draw was {draw}." in text and text.startswith("# Sensorless orientation")
    assert paths["figures"] == []


def test_a_dependency_cycle_is_an_error(tmp_path, monkeypatch):
    (tmp_path / "cycle_section.py").write_text("def run(ctx):\n    return ctx.result('cycle')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    register("cycle", "cycle_section")
    try:
        with pytest.raises(RuntimeError, match="cycle"):
            Context(ReproduceSettings()).result("cycle")
    finally:
        EXPERIMENTS.pop("cycle")
        sys.modules.pop("cycle_section", None)

"""The coverage benchmark's own machinery (benchmarks/bench_coverage.py): kept runs cut back into
sequences, and references simulated once and resumed from disk. Run by ``make bench-test``, not by the
product's suite (``tests/`` never imports ``benchmarks``)."""
import numpy as np

from benchmarks.bench_coverage import _split, kept_references


def test_split_cuts_a_kept_runs_steps_back_into_its_sequences():
    res = {"per_sequence": [{"reference": [0.0] * 31}, {"reference": [0.0] * 21}]}
    inside = np.arange(50) % 3 == 0
    parts = _split(res, inside)
    assert [len(p) for p in parts] == [30, 20]
    assert np.array_equal(np.concatenate(parts), inside)


def test_kept_references_simulate_each_reference_once_and_resume_from_disk(tmp_path, monkeypatch):
    """A stopped run resumes: a reference asked again (even by a new process's simulate) is read back, not
    simulated; another seed, sequence or trial count is simulated anew."""
    from types import SimpleNamespace

    import analysis.validate as av

    calls = []

    def fake(scene, seq, trials, sd, noise):
        calls.append((tuple(seq), trials, sd))
        return {"seq": list(seq), "trials": trials, "seed": sd}

    model = SimpleNamespace(metadata={"scene": {"shape": "toy"}})
    monkeypatch.setattr(av, "model_grid", lambda m: None)
    first = kept_references(str(tmp_path), model, simulate=fake)
    a = first(None, [0, 1, 2], 10, 7, "none")
    again = kept_references(str(tmp_path), model, simulate=fake)     # a new job
    assert again(None, [0, 1, 2], 10, 7, "none") == a and len(calls) == 1
    again(None, [0, 1, 2], 10, 8, "none")
    again(None, [0, 1, 1], 10, 7, "none")
    again(None, [0, 1, 2], 20, 7, "none")
    assert len(calls) == 4
    other = kept_references(str(tmp_path), SimpleNamespace(metadata={"scene": {"shape": "other"}}), simulate=fake)
    other(None, [0, 1, 2], 10, 7, "none")                            # another scene: not the kept one
    assert len(calls) == 5

"""Hostile but fair input: every case answers with exit status 2 and exactly one line on stderr,
before allocating what it asks for (docs/commands.md: bad input)."""
from __future__ import annotations

import numpy as np
import pytest

from analysis.cli import main

FILES = {
    "huge_index.json": '{"states": 3, "actions": {"a": [1, 2, 100000000000000000000], "b": [0, 0, 2]}}',
    "float_index.json": '{"states": 3, "actions": {"a": [1, 2, 1e300], "b": [0, 0, 2]}}',
    "huge_states.json": '{"states": 100000000000, "actions": {"a": {"rows": [0], "cols": [0], "probs": [1.0]}}}',
    "billions.json": '{"states": 3000000000, "actions": {"a": {"rows": [0], "cols": [0], "probs": [1.0]}}}',
    "deep.json": '{"states": 2, "actions": {"a": [1, 1]}, "x": ' + "[" * 100000 + "]" * 100000 + "}",
    "nan_next.json": '{"states": 3, "actions": {"a": [0, NaN, 2]}}',
    "nan_prob.json": '{"states": 2, "actions": {"a": {"rows": [0, 1], "cols": [1, 0], "probs": [1.0, NaN]}}}',
    "ok.json": '{"states": 2, "actions": {"a": [1, 1], "b": [0, 0]}}',
    "far_step.csv": "trial,step,x_mm,y_mm,theta_rad\n0,99999999999,10,10,0\n",
}


@pytest.fixture
def files(tmp_path, monkeypatch):
    for name, text in FILES.items():
        (tmp_path / name).write_text(text)
    # a .npz whose header member is not a .npy array
    np.savez(tmp_path / "fake.npz", initial=np.ones(2))
    import zipfile

    with zipfile.ZipFile(tmp_path / "fake.npz", "a") as z:
        z.writestr("header.npy", b"this is not an npy file")
    # model files whose arrays have the wrong kind: complex probabilities, fractional indices
    import scipy.sparse as sp

    from kruskal_markov.model import TransitionModel

    TransitionModel(["N", "S"], [sp.csr_matrix(np.eye(2))] * 2).save(str(tmp_path / "ok.npz"))
    for name, key, cast in (("complex.npz", "initial", lambda a: a.astype(complex)),
                            ("fraction.npz", "indices_0", lambda a: a.astype(float) + 0.5)):
        arrays = dict(np.load(tmp_path / "ok.npz"))
        arrays[key] = cast(arrays[key])
        np.savez(tmp_path / name, **arrays)
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.mark.parametrize("argv, needle", [
    (["sync", "--automaton", "huge_index.json"], "beyond any state index"),
    (["sync", "--automaton", "float_index.json"], "beyond any state index"),
    (["sync", "--automaton", "nan_next.json"], "nan_next.json: action 'a': next-state list has a non-finite entry nan at position 1"),
    (["entropy", "--automaton", "nan_prob.json", "--sequence", "a"], "nan_prob.json: action 'a': row 1 has a non-finite entry nan"),
    (["entropy", "--automaton", "huge_states.json", "--sequence", "a"], "100,000,000,000 states needs"),
    (["entropy", "--automaton", "billions.json", "--sequence", "a"], "3,000,000,000 states needs"),
    (["entropy", "--automaton", "deep.json", "--sequence", "a"], "nested too deeply"),
    (["entropy", "--automaton", "ok.json", "--sequence", "random:1000000000000"], "use a shorter sequence"),
    (["simulate", "--sequence", "random:1000000000000"], "use a shorter sequence"),
    (["simulate", "--sequence", "N", "--trials", "100000000000"], "use fewer --trials"),
    (["ensemble", "--automaton", "ok.json", "--count", "1000000000000", "--length", "5"], "smaller --count"),
    (["entropy", "--poses", "far_step.csv", "--shape", "allen-key"], "counts tilts from 0"),
    (["entropy", "--model", "fake.npz", "--sequence", "N"], "fake.npz"),
    (["entropy", "--model", "complex.npz", "--sequence", "N"], "initial of the model must be real floating-point"),
    (["entropy", "--model", "fraction.npz", "--sequence", "N"], "indices of action 'N' must be integers"),
    (["simulate", "--shape", "polygon:0,0;1e200,0;0,1e200", "--sequence", "N"], "does not fit in any tray"),
    (["simulate", "--shape", "rectangle:0.5x0.5", "--sequence", "N"], "smallest square part is 2 x 2 mm"),
    (["simulate", "--shape", "rectangle:0.01x0.01", "--sequence", "N"], "too small for the simulator"),
    (["build", "--shape", "rectangle:1.9x1.9"], "0.95 mm inside its outline"),
])
def test_refused_in_one_line_before_allocating(files, capsys, argv, needle):
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1 and needle in err, err
    assert "Traceback" not in err


def test_smallest_supported_part_reaches_the_wall():
    """A 2 x 2 mm square (the smallest the 1 mm support sphere allows) slides flush against the wall
    it is tilted toward: the part's outline touches it, not the sphere."""
    from transition_builder.scene import scene_from_options
    from transition_builder.sim import TraySimulator

    scene = scene_from_options("rectangle:2x2")
    with TraySimulator(scene) as sim:
        rest, status = sim.tilt([[100.0, 100.0, 0.0], [60.0, 120.0, 0.3]], "N")
    assert list(status) == [0, 0]
    top = scene.shape.placed(rest)[..., 1].max(axis=1)
    np.testing.assert_allclose(top, scene.tray_y_mm, atol=0.08)

"""The failure paths a hostile pass found open (issue 31), each closed and held shut by a test:
absurd noise, a lost Dask scheduler, a checkpoint that does not replay, unwritable outputs,
``--length 0``, the build key in the JSON, the total work of a resumed build, one-line cache
warnings, and ``--no-cache`` meaning no reuse of any kind."""
from __future__ import annotations

import contextlib
import json
import os
import warnings

import numpy as np
import pytest

from analysis.cli import main
from transition_builder.builder import BuildSettings, BuildWarning, build_key, build_model
from transition_builder.executors import SerialExecutor, make_executor
from transition_builder.scene import scene_from_options


def _square():
    return scene_from_options("rectangle:30x30", friction_spec=0.1, tray_mm=(90.0, 90.0))


_SETTINGS = BuildSettings(start_samples=150, max_states=1200, seed=3)
#: the builds here run on two kept worker processes (a model is the same on every executor)
BUILDS = make_executor(2)


class _Interrupting(SerialExecutor):
    """Runs tasks in this process and stops (as Ctrl-C would) after ``after`` of them."""

    def __init__(self, after):
        self.after, self.n = after, 0

    def map(self, fn, tasks):
        for i, task in enumerate(tasks):
            self.n += 1
            if self.n > self.after:
                raise KeyboardInterrupt("stopped by the test")
            yield i, fn(*task)


def _one_line_error(err: str, command: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith(f"kruskal {command}: error: "), err
    return lines[0]


@pytest.fixture(scope="module")
def fresh_square():
    return build_model(_square(), _SETTINGS, executor=BUILDS, batch_tilts=160)


@pytest.fixture
def interrupted_checkpoint(tmp_path):
    """A checkpoint of the square build, written by a build stopped after 40 tasks."""
    path = str(tmp_path / "square.ckpt.npz")
    with pytest.raises(KeyboardInterrupt):
        build_model(_square(), _SETTINGS, executor=_Interrupting(40), checkpoint=path, checkpoint_interval_s=0.0,
                    batch_tilts=160)
    assert os.path.exists(path)
    return path


# 1. absurd noise --------------------------------------------------------------------------------

@pytest.mark.parametrize("argv", [
    ["build", "--shape", "rectangle:30x30", "--noise", "pose:1e5,0", "--start-samples", "20", "--max-states", "40",
     "--workers", "1", "--no-cache"],
    ["build", "--shape", "rectangle:30x30", "--noise", "pose:1e308,0", "--start-samples", "20", "--max-states", "40",
     "--workers", "1", "--no-cache"],
    ["simulate", "--shape", "rectangle:30x30", "--noise", "pose:1e5,0", "--sequence", "N,E", "--trials", "4",
     "--workers", "1"],
])
def test_absurd_noise_is_refused_in_one_line_with_the_trays_bound(argv, capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("KRUSKAL_CACHE", str(tmp_path))
    assert main(argv) == 2
    line = _one_line_error(capsys.readouterr().err, argv[0])
    assert "too large for this tray" in line and "at most 50 mm" in line and "200 mm" in line


def test_noise_within_the_bound_is_kept():
    from transition_builder.noise import check_noise_for_tray

    assert str(check_noise_for_tray("pose:22.5,180", 90.0, 120.0)) == "pose:22.5,180"
    with pytest.raises(ValueError, match="at most 22.5 mm"):
        check_noise_for_tray("pose:22.6,0", 90.0, 120.0)
    with pytest.raises(ValueError, match="sigma_deg must be at most 180"):
        check_noise_for_tray("pose:0,181", 90.0, 120.0)


# 2. a lost Dask scheduler -----------------------------------------------------------------------

def test_a_lost_dask_scheduler_ends_in_one_line_naming_it_and_keeps_the_checkpoint(tmp_path):
    distributed = pytest.importorskip("distributed")
    from transition_builder.executors import DaskExecutor, SchedulerLost

    cluster = distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None)
    address = cluster.scheduler_address

    class ClosingDask(DaskExecutor):
        """The real client; the scheduler is closed once exploration has begun."""
        results = 0

        def map(self, fn, tasks):
            for item in super().map(fn, tasks):
                yield item
                ClosingDask.results += 1
                if ClosingDask.results == 3:        # the start tilts done, exploration begun
                    cluster.sync(cluster.scheduler.close)

    executor = ClosingDask(address)
    ckpt = str(tmp_path / "c.ckpt.npz")
    try:
        with pytest.raises(SchedulerLost) as info:
            build_model(_square(), BuildSettings(start_samples=48, max_states=1200, seed=3), executor=executor,
                        checkpoint=ckpt, checkpoint_interval_s=0.0, batch_tilts=160)
    finally:
        executor.close()
        with contextlib.suppress(Exception):        # its scheduler is gone: do not wait for it
            cluster.close(timeout=1)
    message = str(info.value)
    assert "\n" not in message and address in message
    assert f"checkpoint {ckpt} kept" in message and os.path.exists(ckpt)
    assert isinstance(info.value, OSError)        # the command line's one-line error, exit 2


# 3. a checkpoint that does not replay; 9. a corrupt checkpoint -------------------------------------

def test_a_checkpoint_that_does_not_replay_is_set_aside_and_the_build_starts_again(interrupted_checkpoint,
                                                                                   fresh_square):
    with np.load(interrupted_checkpoint, allow_pickle=False) as z:
        arrays = {k: np.array(z[k]) for k in z.files}
    explored = np.flatnonzero(arrays["explored"])
    assert len(explored)
    arrays["land"][explored[0], :, 0, 0] += 7.0        # landings far from every representative
    np.savez(interrupted_checkpoint, **arrays)
    with pytest.warns(BuildWarning) as record:
        r = build_model(_square(), _SETTINGS, executor=BUILDS, checkpoint=interrupted_checkpoint,
                        batch_tilts=160)
    (w,) = [w for w in record if issubclass(w.category, BuildWarning)]
    text = str(w.message)
    assert "\n" not in text and interrupted_checkpoint in text and "no representative within tolerance" in text
    assert os.path.exists(interrupted_checkpoint + ".rejected")
    assert not r.stats["resumed"] and r.model.same_arrays(fresh_square.model)


def test_a_corrupt_checkpoint_is_named_in_a_warning_not_dropped_silently(tmp_path, fresh_square):
    path = str(tmp_path / "c.ckpt.npz")
    with open(path, "wb") as f:
        f.write(os.urandom(2000))
    with pytest.warns(BuildWarning, match=r"checkpoint .*c\.ckpt\.npz cannot be resumed: it does not read"):
        r = build_model(_square(), _SETTINGS, executor=BUILDS, checkpoint=path, batch_tilts=160)
    assert r.model.same_arrays(fresh_square.model) and os.path.exists(path + ".rejected")


def test_no_cache_resumes_no_checkpoint(tmp_path, interrupted_checkpoint):
    from transition_builder.cache import cached_build

    key = build_key(_square(), _SETTINGS)
    os.replace(interrupted_checkpoint, tmp_path / f"{key}.ckpt.npz")
    r, _, cached = cached_build(_square(), _SETTINGS, use_cache=False, directory=str(tmp_path),
                                executor=BUILDS, batch_tilts=160)
    assert not cached and not r.stats["resumed"]


# 7. a resumed build records the total work -----------------------------------------------------

def test_a_resumed_build_records_the_work_of_every_run(interrupted_checkpoint, fresh_square):
    r = build_model(_square(), _SETTINGS, executor=BUILDS, checkpoint=interrupted_checkpoint,
                    batch_tilts=160)
    assert r.stats["resumed"] and r.model.same_arrays(fresh_square.model)
    total = fresh_square.stats["tilts_simulated"]
    assert r.stats["tilts_simulated"] == total == r.model.metadata["stats"]["tilts_simulated"]
    assert 0 < r.stats["tilts_this_run"] < total


# 4. output paths probed before any work ----------------------------------------------------------

@pytest.mark.parametrize("argv, option", [
    (["build", "--shape", "rectangle:30x30", "--start-samples", "20", "--workers", "1", "--out",
      "/proc/kruskal-test-model.npz"], "--out"),
    (["simulate", "--shape", "rectangle:30x30", "--sequence", "N,E", "--trials", "4", "--workers", "1",
      "--poses", "/proc/kruskal-test-poses.csv"], "--poses"),
])
def test_an_unwritable_output_is_refused_before_any_work_naming_the_option(argv, option, capsys, tmp_path,
                                                                           monkeypatch):
    monkeypatch.setenv("KRUSKAL_CACHE", str(tmp_path))
    assert main(argv) == 2
    line = _one_line_error(capsys.readouterr().err, argv[0])
    assert f"{option} '/proc/kruskal-test-" in line and "not writable" in line
    assert os.listdir(tmp_path) == []        # nothing built, nothing cached


# 5. --length 0 refused everywhere alike -----------------------------------------------------------

@pytest.mark.parametrize("command", ["ensemble", "validate"])
def test_length_zero_is_refused_alike(command, capsys, tmp_path):
    from kruskal_markov.automaton_json import model_from_automaton

    path = tmp_path / "c4.json"
    path.write_text(json.dumps({"states": 4, "actions": {"a": [1, 2, 3, 0], "b": [1, 1, 2, 3]}}))
    model = tmp_path / "m.npz"
    model_from_automaton(json.loads(path.read_text())).save(str(model))
    argv = (["ensemble", "--automaton", str(path), "--count", "5", "--length", "0"] if command == "ensemble"
            else ["validate", "--model", str(model), "--length", "0"])
    assert main(argv) == 2
    assert _one_line_error(capsys.readouterr().err, command).endswith("--length must be at least 1, got 0")


# 6. the key in build --json; 8. one-line cache warnings ------------------------------------------

def test_build_json_has_the_key_and_a_corrupt_cache_warns_in_one_line(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("KRUSKAL_CACHE", str(tmp_path))
    argv = ["build", "--shape", "rectangle:30x30", "--friction", "0.1", "--start-samples", "40", "--max-states",
            "200", "--seed", "1", "--workers", "1", "--json"]
    assert main(argv) == 0
    first = json.loads(capsys.readouterr().out)
    scene = scene_from_options("rectangle:30x30", friction_spec=0.1)
    key = build_key(scene, BuildSettings(start_samples=40, max_states=200, seed=1))
    assert first["key"] == key and first["model"] == str(tmp_path / f"{key}.npz")
    with open(first["model"], "wb") as f:
        f.write(os.urandom(3000))                    # random bytes: numpy would advise loading "unsafely"
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        assert main(argv) == 0
    out = capsys.readouterr()
    assert json.loads(out.out)["key"] == key
    lines = [ln for ln in out.err.splitlines() if ln.strip()]
    assert lines == [f"kruskal build: warning: cached model {first['model']} is damaged or not a kruskal model; "
                     "rebuilding it"]
    assert main(argv) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["cached"] and again["key"] == key

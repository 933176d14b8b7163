"""The package as a user installs it: a (non-editable) wheel of the source tree holds every module
and data file the commands need. The wheel is installed into a fresh directory and imported from
there -- not from the source tree -- and its `kruskal` entry point answers."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile

import pytest

import tests

ROOT = tests.ROOT


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    wheels = tmp_path_factory.mktemp("wheel")
    target = tmp_path_factory.mktemp("site")
    # build from a copy of the tracked sources, so nothing is written into the working tree
    source = tmp_path_factory.mktemp("source")
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, source / name)
    for package in ("kruskal_markov", "transition_builder", "analysis"):
        shutil.copytree(ROOT / package, source / package, ignore=shutil.ignore_patterns("__pycache__"))
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                            "--quiet", "-w", str(wheels), str(source)], capture_output=True, text=True)
    if build.returncode != 0:
        pytest.fail(f"pip wheel failed: {build.stderr[-2000:]}")
    wheel = next(wheels.glob("kruskal-*.whl"))
    with zipfile.ZipFile(wheel) as z:
        z.extractall(target)            # what `pip install --no-deps` puts in site-packages
    return wheel, target


def _run(target, code):
    env = dict(os.environ, PYTHONPATH=str(target))
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                          cwd=str(target.parent))


def test_wheel_imports_from_the_installed_copy(installed):
    wheel, target = installed
    res = _run(target, "import kruskal_markov, transition_builder, analysis; "
                       "from kruskal_markov import TransitionModel, batch_entropy, shortest_synchronizing_word; "
                       "from transition_builder import Scene, scene_from_options, TraySimulator; "
                       "from analysis import run_direct; "
                       "print(kruskal_markov.__file__); print(transition_builder.__file__); print(analysis.__file__)")
    assert res.returncode == 0, res.stderr
    for line in res.stdout.split():
        assert line.startswith(str(target)), f"imported from {line}, not from the installed wheel"
    names = zipfile.ZipFile(wheel).namelist()
    assert not any(n.startswith(("tests/", "benchmarks/", "reports/")) for n in names)
    assert any(n.endswith("entry_points.txt") for n in names)


def test_installed_entry_point_runs_a_command(installed, tmp_path):
    _, target = installed
    automaton = tmp_path / "cerny4.json"
    automaton.write_text('{"states": 4, "actions": {"a": [1, 2, 3, 0], "b": [0, 1, 2, 0]}}')
    res = _run(target, "import sys; from analysis.cli import main; "
                       f"sys.exit(main(['sync', '--automaton', {str(automaton)!r}, '--json']))")
    assert res.returncode == 0, res.stderr
    import json

    out = json.loads(res.stdout)
    assert out["length"] == 9 and out["exact"] is True     # Cerny C_4: (n - 1)^2
    res = _run(target, "import sys; from analysis.cli import main; sys.exit(main(['--help']))")
    assert res.returncode == 0 and "simulate" in res.stdout and "build" in res.stdout

"""No tracked file names a path of the machine it was written on.

Every text file git tracks (code, documents, the committed report's ``results.json``, the benchmarks'
data) is read: a model is named by its cache key (``transition_builder.cache.cache_key``), a command
a document cites is one a reader can run from a checkout (a script a figure depends on lives in
``benchmarks/`` or ``tools/``), and a job's circumstances are said in words ("one core, beside another
job"), never by the development machine's work tree, scratch space or home directory.
"""
from __future__ import annotations

import re
import subprocess

import pytest

import tests

ROOT = tests.ROOT
#: absolute paths of a development machine: the work tree, scratch space, home directories
MACHINE_PATH = re.compile(r"(?<![\w.~])/(?:work|tmp|root|home|Users|mnt|var/folders)/[\w.+-]")
#: the examples below, spelled so that this file does not hold what it looks for
_W, _T = "/" + "work/", "/" + "tmp/"


def tracked_files() -> list[str]:
    """The files git tracks in the checkout (relative paths)."""
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError) as e:       # not a git checkout (an unpacked sdist)
        pytest.skip(f"not a git checkout: {e}")
    return [f for f in out.decode().split("\0") if f]


def machine_paths(root, files) -> list[str]:
    """``file:line: text`` of every line of the text files ``files`` (under ``root``) that cites a
    machine path; binary files (a NUL byte, or not UTF-8) are skipped."""
    found = []
    for name in files:
        path = root / name
        if not path.is_file():                        # deleted in the work tree, not yet committed
            continue
        data = path.read_bytes()
        if b"\0" in data[:8192]:
            continue
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError:
            continue
        found += [f"{name}:{i}: {line.strip()[:160]}" for i, line in enumerate(text.splitlines(), 1)
                  if MACHINE_PATH.search(line)]
    return found


def test_no_tracked_file_cites_a_path_of_the_development_machine():
    files = tracked_files()
    assert len(files) > 100 and "reports/full/results.json" in files    # the whole checkout is read
    found = machine_paths(ROOT, files)
    assert not found, "\n".join(found)


def test_a_planted_path_is_found_in_any_text_file_and_binaries_are_skipped(tmp_path):
    (tmp_path / "results.json").write_text('{"model": {"cache_key": "ab12.npz"},\n "x": "' + _W + 'cache/ab12.npz"}\n')
    (tmp_path / "bench.py").write_text("# run beside ``" + _T + "s43/job.sh``\n")
    (tmp_path / "clean.md").write_text("`python tools/house.py`, `reports/full/index.md`\n")
    (tmp_path / "fig.png").write_bytes(b"\x89PNG\r\n\x1a\n\0\0" + (_W + "x").encode())
    found = machine_paths(tmp_path, ["results.json", "bench.py", "clean.md", "fig.png", "gone.txt"])
    assert [f.split(":")[:2] for f in found] == [["results.json", "2"], ["bench.py", "1"]]


def test_the_pattern_finds_what_it_is_for():
    assert MACHINE_PATH.search("`" + _W + "wt/heavy python -m benchmarks.bench_fit logs`")
    assert MACHINE_PATH.search("(`" + _T + "s43/job.sh`)")
    assert MACHINE_PATH.search('"model_path": "/' + 'root/.cache/kruskal/models/ab.npz"')
    assert MACHINE_PATH.search('"/' + 'Users/me/kruskal/x.npz"')
    assert not MACHINE_PATH.search("`python tools/mutate.py`, `reports/full/index.md`, build/mutate/x/")
    assert not MACHINE_PATH.search("https://example.org/work/x and ~/work/x")
    assert not MACHINE_PATH.search(_T)                  # .gitignore's pattern of the checkout's own tmp/

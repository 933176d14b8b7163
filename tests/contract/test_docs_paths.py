"""The documents name commands a reader can run from a checkout: no README or ``docs/*.md`` cites a
path of the machine the project was developed on (a lock wrapper, a scratch script, a session's
log) as the command behind a figure. A job's circumstances are said in words instead ("one core,
beside another job"); a script a figure depends on lives in ``benchmarks/`` or ``tools/``."""
from __future__ import annotations

import re

import pytest

import tests

ROOT = tests.ROOT
#: absolute paths of the development machine (``/work/...``, ``/tmp/...``, a home directory)
MACHINE_PATH = re.compile(r"(?<![\w.~])/(?:work|tmp|root|home)/[\w.+-]")
DOCS = sorted(["README.md"] + [p.relative_to(ROOT).as_posix() for p in (ROOT / "docs").glob("*.md")])


@pytest.mark.parametrize("doc", DOCS)
def test_no_document_cites_a_path_of_the_development_machine(doc):
    lines = (ROOT / doc).read_text().splitlines()
    found = [f"{doc}:{i}: {line.strip()}" for i, line in enumerate(lines, 1) if MACHINE_PATH.search(line)]
    assert not found, "\n".join(found)


def test_the_pattern_finds_what_it_is_for():
    assert MACHINE_PATH.search("`/work/wt/heavy python -m benchmarks.bench_fit logs`")
    assert MACHINE_PATH.search("(`/tmp/s43/job.sh`)")
    assert not MACHINE_PATH.search("`python tools/mutate.py`, `reports/full/index.md`, build/mutate/x/")
    assert not MACHINE_PATH.search("https://example.org/work/x and ~/work/x")

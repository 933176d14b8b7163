"""tools/rerun_section.py: one section of a report re-run in place, with the report's own settings."""
import dataclasses
import importlib.util
import json

import pytest

import tests
from analysis.reproduce import ReproduceSettings

_spec = importlib.util.spec_from_file_location("rerun_section", str(tests.ROOT / "tools" / "rerun_section.py"))
rerun = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rerun)

INDEX = "# Title\n\nintro\n\n## A\n\nold a\n\n## B\n\nold b\nmore b\n\n## C\n\nc\n"


@pytest.mark.parametrize("make", [ReproduceSettings.full, ReproduceSettings.quick_settings])
def test_settings_come_back_from_results_json(make):
    s = make(seed=3)
    saved = json.loads(json.dumps(dataclasses.asdict(s)))         # as results.json stores them
    assert rerun.settings_from_results(saved) == s


def test_unknown_settings_are_refused():
    saved = json.loads(json.dumps(dataclasses.asdict(ReproduceSettings.full())))
    saved["no_such_setting"] = 1
    with pytest.raises(ValueError, match="no_such_setting"):
        rerun.settings_from_results(saved)


def test_splice_replaces_only_its_section():
    out = rerun.splice_section(INDEX, "## B\n\nnew b\n")
    assert out == "# Title\n\nintro\n\n## A\n\nold a\n\n## B\n\nnew b\n\n## C\n\nc\n"
    last = rerun.splice_section(INDEX, "## C\n\nnew c")
    assert last.endswith("## C\n\nnew c\n\n") and "old b\nmore b" in last
    with pytest.raises(ValueError, match="no section"):
        rerun.splice_section(INDEX, "## D\n\nd\n")
    with pytest.raises(ValueError, match="heading"):
        rerun.splice_section(INDEX, "B without a heading\n")


def test_splice_puts_a_new_section_before_a_heading_or_at_the_end():
    out = rerun.splice_section(INDEX, "## A2\n\nnew\n", before="## B")
    assert out == "# Title\n\nintro\n\n## A\n\nold a\n\n## A2\n\nnew\n\n## B\n\nold b\nmore b\n\n## C\n\nc\n"
    assert rerun.splice_section(INDEX, "## D\n\nd\n", before="END").endswith("## C\n\nc\n\n## D\n\nd\n")
    assert rerun.splice_section(INDEX, "## B\n\nnew b\n", before="## C") == rerun.splice_section(INDEX, "## B\n\nnew b\n")
    with pytest.raises(ValueError, match="to put"):
        rerun.splice_section(INDEX, "## D\n\nd\n", before="## Z")

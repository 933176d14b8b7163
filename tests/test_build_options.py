"""Each build option is defined once (``transition_builder.builder.options.BUILD_OPTIONS``): the
settings class has its field, the command line its flag, and docs/builder.md its row."""
from __future__ import annotations

import dataclasses
import os

from analysis.cli import build_parser
from transition_builder.builder import BUILD_OPTIONS, BuildSettings, options_markdown

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_every_option_is_a_settings_field_and_a_flag():
    fields = {f.name for f in dataclasses.fields(BuildSettings)}
    build = build_parser()._subparsers._group_actions[0].choices["build"]
    flags = {s for a in build._actions for s in a.option_strings}
    for option in BUILD_OPTIONS:
        assert option.name in fields and option.flag in flags
        assert option.flag == "--" + option.name.replace("_", "-")


def test_the_docs_table_is_the_generated_one():
    with open(os.path.join(ROOT, "docs", "builder.md"), encoding="utf-8") as f:
        text = f.read()
    assert options_markdown() in text, "docs/builder.md: paste options_markdown()'s table between its markers"

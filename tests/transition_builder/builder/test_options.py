"""Each build option is defined once (``transition_builder.builder.options.BUILD_OPTIONS``): the
settings class has its field (in the table's order, with its docstring entry), the command line its
flag, and docs/builder.md its row."""
from __future__ import annotations

import dataclasses
import inspect
import os

import pytest

import tests
from analysis.cli import build_parser
from transition_builder.builder import BUILD_OPTIONS, BuildSettings, options_markdown

ROOT = str(tests.ROOT)


def test_every_option_is_a_settings_field_and_a_flag():
    build = build_parser()._subparsers._group_actions[0].choices["build"]
    flags = {s for a in build._actions for s in a.option_strings}
    assert [o.name for o in BUILD_OPTIONS] == [f.name for f in dataclasses.fields(BuildSettings)]
    for option in BUILD_OPTIONS:
        assert f"\n{option.name} : " in inspect.getdoc(BuildSettings), f"{option.name} has no Attributes entry"
        if option.flag is not None:
            assert option.flag == "--" + option.name.replace("_", "-") and option.flag in flags
        elif option.via:          # set by another flag: `--resolution MM,DEG`
            assert option.via.strip("`").split()[0] in flags


def test_defaults_and_checks_come_from_the_table():
    for option in BUILD_OPTIONS:
        field = BuildSettings.__dataclass_fields__[option.name]
        assert field.default == option.default and field.type == option.annotation
        assert option.auto is None or option.default is None, option.name
    with pytest.raises(ValueError, match="build setting theta_offset must be a finite number"):
        BuildSettings(theta_offset=float("inf"))
    with pytest.raises(ValueError, match="unknown build setting.s. bogus; known: adaptive"):
        BuildSettings.from_dict({"bogus": 1})


def test_the_docs_table_is_the_generated_one():
    with open(os.path.join(ROOT, "docs", "builder.md"), encoding="utf-8") as f:
        text = f.read()
    assert options_markdown() in text, "docs/builder.md: paste options_markdown()'s table between its markers"

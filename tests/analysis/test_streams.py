"""analysis.streams: one table of every random stream of ``analysis``.

The salts are pinned by value (a changed salt changes published figures), no other module of
``analysis`` seeds a generator with an integer of its own, and every stream name the report's
sections draw from is in the table of named streams.
"""
from __future__ import annotations

import ast
import re

import numpy as np

import tests
from analysis.streams import REPORT_STREAMS, SALTS, offset_seed, salted, salted_rng, stream_seed

ANALYSIS = tests.ROOT / "analysis"
#: calls that take a seed: a list literal with an integer constant in one of them is a salt
SEEDING = {"default_rng", "SeedSequence", "salted", "salted_rng"}


def test_the_salts_keep_the_values_every_published_output_was_drawn_with():
    assert SALTS == {"sequences": 1, "validate.reference": 2, "validate.bootstrap": 3, "validate.posterior": 4,
                     "orientability.entropy_tilts": 5, "orientability.sync_length": 6, "fit": 0x464954,
                     "tray_log": 0x7E41, "tray_log.camera": 0xCA, "kit.compartment": 0x6B6974}
    assert len(set(SALTS.values())) == len(SALTS)                     # two uses never share a stream
    assert salted(np.int64(9), "validate.posterior", 3) == [9, 4, 3]
    a, b = salted_rng(5, "fit", 1).random(4), np.random.default_rng([5, 0x464954, 1]).random(4)
    np.testing.assert_array_equal(a, b)
    assert offset_seed(10, 2) == 12


def test_named_streams_are_unrelated_across_names_and_seeds():
    seeds = {stream_seed(s, n) for s in range(4) for n in ("A", "A.check", "B:triangle:1", "B:triangle:2")}
    assert len(seeds) == 16 and all(0 <= x < 2 ** 31 for x in seeds)


def _integer_salts(path, root=tests.ROOT) -> list[str]:
    """``file:line`` of every seeding call in ``path`` given a list literal holding an integer."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if not isinstance(node, ast.Call):
            continue
        name = getattr(node.func, "attr", getattr(node.func, "id", ""))
        args = list(node.args) + [k.value for k in node.keywords if k.arg == "seed"]
        if name in SEEDING or any(k.arg == "seed" for k in node.keywords):
            for a in args:
                if isinstance(a, ast.List) and any(isinstance(e, ast.Constant) and isinstance(e.value, int)
                                                   for e in a.elts):
                    found.append(f"{path.relative_to(root)}:{node.lineno}")
    return found


def test_no_module_but_the_table_salts_a_seed_with_its_own_integer():
    found = [f for p in sorted(ANALYSIS.rglob("*.py")) if p.name != "streams.py" for f in _integer_salts(p)]
    assert not found, found


def test_the_salt_finder_finds_a_bare_salt(tmp_path):
    (tmp_path / "m.py").write_text("import numpy as np\nr = np.random.default_rng([seed, 3])\n"
                                   "f(x, seed=[seed, 5])\nok = np.random.default_rng(seed)\n")
    assert _integer_salts(tmp_path / "m.py", root=tmp_path) == ["m.py:2", "m.py:3"]


#: a stream name where the report's sections name one: ``ctx.seed("x")``, ``ctx.ensemble(m, n, "x")``,
#: ``ctx.direct(scene, w, n, f"x:{...}")``, ``plan_replay(..., "x")``
_NAMED = re.compile(r'(?:\.seed|\.rng)\(f?"([^"]+)"|(?:ctx\.ensemble|ctx\.direct|plan_replay)\([^"\n]*, f?"([^"]+)"')


def test_every_stream_the_report_draws_from_is_in_the_table():
    used = set()
    for p in (ANALYSIS / "experiments").glob("*.py"):
        if p.name == "__init__.py":                                     # its how-to names an example
            continue
        for m in _NAMED.finditer(p.read_text()):
            used.add((m.group(1) or m.group(2)).split(":")[0])
    assert {"A", "A.check", "B", "C", "ensemble", "sync.replay", "tray_log"} <= used    # the finder finds them
    assert used <= set(REPORT_STREAMS), sorted(used - set(REPORT_STREAMS))

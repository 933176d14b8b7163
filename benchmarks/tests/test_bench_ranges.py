"""The ranking-stability driver (benchmarks/bench_ranges.py): its default build options are the
design docs/ranges.md names, and its summaries read the pieces each lock job leaves."""
from __future__ import annotations

import json

from benchmarks import bench_ranges as br


def test_default_options_are_the_named_design():
    """docs/ranges.md section 2: 2 mm / 2 degrees, one recentring round, 2,000 starts, seed 0."""
    opts = dict(zip(br.OPTIONS[::2], br.OPTIONS[1::2]))
    assert opts == {"--resolution": "2,2", "--recenter-rounds": "1", "--start-samples": "2000", "--seed": "0"}
    assert len(br.PARTS) == 19 and len(set(br.PARTS)) == 19


def test_build_summary_keeps_fresh_builds_at_the_design(tmp_path):
    rows = [{"shape": "triangle:1", "mu": "0.4", "options": list(br.OPTIONS), "cached": False, "states": 50,
             "wall_seconds": 3.0},
            {"shape": "allen-key", "mu": "0.2", "options": list(br.OPTIONS), "cached": False, "states": 40,
             "wall_seconds": 2.0},
            {"shape": "allen-key", "mu": "0.2", "options": list(br.OPTIONS), "cached": True, "states": 40,
             "wall_seconds": 0.1},                                          # a cache hit: not a build time
            {"shape": "allen-key", "mu": "0.4", "options": ["--resolution", "1,1"], "cached": False, "states": 9,
             "wall_seconds": 9.0}]                                          # another design
    (tmp_path / "builds.jsonl").write_text("\n".join(json.dumps(r) for r in rows) + "\n")
    out = br.summarise_builds(tmp_path)
    assert [(r["shape"], r["mu"], r["wall_seconds"]) for r in out] == [("allen-key", "0.2", 2.0), ("triangle:1", "0.4", 3.0)]


def test_rank_summary_from_the_two_ends(tmp_path):
    ends = {"0.2": ["a", "b", "c"], "0.4": ["b", "a", "c"]}
    for mu, order in ends.items():
        (tmp_path / f"rank_{mu}.json").write_text(json.dumps(
            {"ranking": [{"shape": s, "rank": k + 1} for k, s in enumerate(order)]}))
    out = br.summarise_rank(tmp_path)
    assert out["rank_range"] == {"a": [1, 2], "b": [1, 2], "c": [3, 3]}
    assert out["orders_that_flip"] == [["a", "b"]]
    assert sorted(map(tuple, out["orders_that_hold"])) == [("a", "c"), ("b", "c")]
    assert abs(out["kendall_tau_ends"] - 1 / 3) < 1e-9
    (tmp_path / "rank_0.4.json").unlink()
    assert br.summarise_rank(tmp_path) is None                  # one end missing: nothing claimed

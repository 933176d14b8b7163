"""The plan search's transposition table and its memory budget (docs/plans.md, IDA*): a quarter of
``memory_budget_mb`` holds the table's entries, 48 bytes each, and it is said in the notes when a pass
fills it; the answer is the same either way (memory never costs exactness)."""
from __future__ import annotations

import numpy as np

from kruskal_markov.automaton_json import model_from_automaton
from kruskal_markov.sync import shortest_plan

#: bytes of one entry (two 16-byte hash slots, the offset, the length and the depth)
ENTRY_BYTES = 48
MAX_LENGTH = 20


def _no_plan_instance():
    """A random 14-state, 3-letter automaton ``A`` (seed 12) beside a copy ``A'`` of itself, each
    letter acting on both alike, from every state. Cells: state ``q`` of ``A`` in cell ``q``, its copy
    in cell ``q + 1 (mod 14)``: an image ``X u X'`` spans the cells ``X u (X + 1)``, at least two, so no
    word meets the ``cell`` target, and the images are those of ``A``."""
    table = np.random.default_rng(12).integers(0, 14, (3, 14)).tolist()
    n = 14
    model = model_from_automaton({"states": 2 * n, "actions": {
        name: row + [x + n for x in row] for name, row in zip("abc", table)}})
    cells = list(range(n)) + [(q + 1) % n for q in range(n)]
    return table, model, cells


def _reachable_images(table):
    """Every image of the start set under a word of one letter or more (breadth first, plain Python):
    the distinct images an exhaustive pass can record, with the states each one pools (twice its
    size: the image and its copy)."""
    n = len(table[0])
    front, seen = {frozenset(range(n))}, set()
    while front:
        front = {frozenset(row[q] for q in s) for s in front for row in table} - seen
        seen |= front
    return len(seen), sum(2 * len(s) for s in seen)


def _plan(model, cells, entries):
    """The search with a budget whose table holds exactly ``entries`` entries (a quarter of it
    divided by 48 bytes, rounded down)."""
    mb = (ENTRY_BYTES * entries + ENTRY_BYTES / 2) * 4 / 2 ** 20
    return shortest_plan(model, "cell", cells=[cells], beam_width=1, max_length=MAX_LENGTH, memory_budget_mb=mb)


def _full_passes(r):
    return [int(x.split("depth-")[1].split()[0]) for x in r.notes if x.startswith("transposition table full")]


def test_a_table_with_room_for_every_image_never_fills_and_one_with_fewer_says_so():
    """The instance has K images (over 1,024, the table's floor), all within 17 letters. A table of
    K + 1 entries never fills: no pass records more than the K distinct images there are; nor does
    one of exactly K entries, which holds every image and turns none away. With K - 1
    entries the last passes (which reach every image) fill it and say so. The states pooled with the
    entries (another quarter of the budget, 4 bytes a state) have room for every image in both. The
    answer is the same: no plan of length <= 20, proven up to that length only."""
    table, model, cells = _no_plan_instance()
    K, pooled = _reachable_images(table)
    assert 1024 < K and pooled + 2 * 14 < 12 * (K - 1)
    roomy, exact_fit, tight = _plan(model, cells, K + 1), _plan(model, cells, K), _plan(model, cells, K - 1)
    assert _full_passes(roomy) == [] and _full_passes(exact_fit) == []
    full = _full_passes(tight)
    assert full and full[-1] == MAX_LENGTH and full == list(range(full[0], MAX_LENGTH + 1))
    for r in (roomy, exact_fit, tight):
        assert (r.word, r.exact, r.lower_bound, r.method) == (None, False, MAX_LENGTH + 1, "ida*")
        assert r.notes[-1] == f"no plan of length <= {MAX_LENGTH}"

"""The exact reset-word search's phases as a user sees them: the answer, its work and the documented
``observe`` events (``ExactSearchOptions``) -- the last length met without storing its level, from
either side; a no-answer proven by the depth-first phase; large levels on the thread-split path;
the depth-first phase's batches."""
from __future__ import annotations

import numpy as np
import pytest

from kruskal_markov import generators
from kruskal_markov.sync import ExactSearchOptions, SyncAutomaton, is_synchronizing_word, shortest_synchronizing_word
from tests.kruskal_markov.sync.test_exact import brute


def _events(**kw):
    """Options that record the search's ``observe`` events, and the list they go to."""
    seen = []
    return ExactSearchOptions(observe=lambda e, v: seen.append((e, v)), **kw), seen


def _random(seed, n, k):
    return np.random.default_rng(seed).integers(0, n, (k, n)).tolist()


def test_the_last_length_is_met_unstored_from_either_side_and_its_sets_are_counted():
    """A 12-state, 3-letter automaton whose Eppstein word (9 letters) is shortest (brute force): the
    search reaches length 8, the last one to rule out, and generates that level without storing it
    (event ``last-level``, its sets). Forward images or backward preimages generate different
    numbers of sets, but the sets stored before are the same, so the work reported minus the last
    level's sets is the same from either side and by the default rule."""
    table = [[6, 5, 3, 11, 1, 2, 8, 7, 0, 10, 4, 4], [1, 8, 8, 4, 1, 11, 10, 6, 4, 0, 2, 3],
             [2, 5, 7, 6, 11, 3, 0, 10, 6, 10, 4, 10]]
    assert brute(table) == 9
    aut = SyncAutomaton.from_table(table)
    stored, last = {}, {}
    for side in (None, "forward", "backward"):
        options, seen = _events(use_beam=False, fast_nodes=None, last_side=side)
        r = shortest_synchronizing_word(aut, time_budget=None, options=options)
        assert (r.length, r.exact, r.method, r.lower_bound) == (9, True, "greedy-eppstein+lower-bound", 9)
        assert is_synchronizing_word(aut, r.word)
        generated = [v for e, v in seen if e == "last-level"]
        assert len(generated) == 1 and generated[0] > 0
        last[side] = generated[0]
        stored[side] = r.states_explored - generated[0]
    assert last["forward"] != last["backward"]
    assert stored["forward"] == stored["backward"] == stored[None] > 0


def test_a_no_answer_proven_by_the_depth_first_phase():
    """Two copies of a random 14-state automaton (each letter acting on both alike): no word merges a
    state with its copy. With 0.0001 MB the pair-graph check does not fit (it is skipped), and the
    stores fill (1,024 sets each) before either direction is exhausted, so the depth-first phase
    starts and finds every frontier set holding a pair that never merges: no word, proven."""
    table = _random(12, 14, 3)
    doubled = [row + [q + 14 for q in row] for row in table]
    options, seen = _events()
    r = shortest_synchronizing_word(SyncAutomaton.from_table(doubled), time_budget=None, memory_budget_mb=1e-4,
                                    options=options)
    assert ("depth-first", 14) in seen
    assert (r.word, r.length, r.exact, r.method) == (None, None, True, "bidirectional-bfs")
    assert r.witness == {"kind": "exhaustive", "subsets_explored": r.states_explored,
                         "reason": "exhaustive subset search: no image of the start set is a single state"}


@pytest.mark.parametrize("parallel", [False, True])
def test_large_levels_take_the_thread_split_path_with_the_same_answers(parallel):
    """Random 120-state, 2-letter automata whose levels pass 8,192 sets, the size from which the
    subset trie's queries may be split over threads: a backward level checked for dominance (seed 1:
    over 9,000 sets) and a last level of preimages met against the forward trie (seed 6: over 13,000
    sets). With threads on or off the answers are the default search's, and the words synchronize."""
    for seed, kw, event in ((1, dict(backward_dominance=True, use_beam=False), "backward-level"),
                            (6, dict(last_side="backward"), "last-level")):
        aut = SyncAutomaton.from_table(_random(seed, 120, 2))
        plain = shortest_synchronizing_word(aut, time_budget=None, options=ExactSearchOptions(parallel=parallel))
        options, seen = _events(fast_nodes=None, parallel=parallel, **kw)
        r = shortest_synchronizing_word(aut, time_budget=None, options=options)
        assert max(v for e, v in seen if e == event) >= 8192
        assert (r.length, r.exact) == (plain.length, True) and is_synchronizing_word(aut, r.word)


def test_the_depth_first_phase_expands_no_empty_batch():
    """Random 6- to 12-state automata searched depth-first from small levels (``dfs_switch_rows`` 4,
    the forward phase, chunks of 2 sets): every batch the phase reports expanding holds a set (a chunk
    whose sets the pair distances all prune is not expanded), and the answers are brute force's."""
    batches = 0
    for seed in range(12):
        rng = np.random.default_rng(seed)
        n = int(rng.integers(6, 13))
        table = rng.integers(0, n, (2, n)).tolist()
        options, seen = _events(inverse_dfs=False, dfs_switch_rows=4, use_beam=False, fast_nodes=None, dfs_chunk=2)
        r = shortest_synchronizing_word(SyncAutomaton.from_table(table), time_budget=None, options=options)
        assert r.length == brute(table)
        sizes = [v for e, v in seen if e == "dfs-batch"]
        assert all(v > 0 for v in sizes), (seed, sizes)
        batches += len(sizes)
    assert batches > 20


@pytest.mark.parametrize("forward", [True, False])
def test_dominance_against_the_earlier_levels_keeps_fewer_sets(forward):
    """``forward_visited`` / ``backward_visited``: a new set is also checked against the direction's
    earlier levels, not only its own level. On a random binary automaton of 60 states (either
    direction's dominance on) that keeps fewer subsets than the check within the level, with the
    same shortest length (counts of subsets, machine-independent)."""
    aut = SyncAutomaton.from_table(generators.random_table(60, 2, 4363))
    got = {}
    for visited in (False, True):
        options = ExactSearchOptions(use_beam=False, forward_dominance=forward, backward_dominance=not forward,
                                     forward_visited=visited, backward_visited=visited)
        got[visited] = shortest_synchronizing_word(aut, time_budget=None, options=options)
    assert got[True].length == got[False].length == 22 and got[True].exact and got[False].exact
    assert is_synchronizing_word(aut, got[True].word)
    assert got[True].states_explored < got[False].states_explored


@pytest.mark.parametrize("m", [3, 6, 9])
def test_forward_sets_that_cannot_start_a_shorter_word_end_the_search(m):
    """A ladder on states 0..m: ``a`` moves every state one step down (0 stays), ``b`` changes nothing.
    The shortest word is a^m (brute force) and Eppstein's word has m letters. The only new forward set
    after one letter, {0, .., m - 1}, holds states 0 and m - 1, which no word shorter than m - 1 letters
    merges, more than the m - 2 left for a word shorter than m: the pair-distance pruning drops it and
    the greedy word is proven shortest after that one level, with two sets stored (the start and the
    backward root {0})."""
    table = [[max(q - 1, 0) for q in range(m + 1)], list(range(m + 1))]
    assert brute(table) == m
    options, seen = _events(use_beam=False, fast_nodes=None)
    r = shortest_synchronizing_word(SyncAutomaton.from_table(table), time_budget=None, options=options)
    assert (r.length, r.exact, r.method, r.greedy_length) == (m, True, "greedy-eppstein+lower-bound", m)
    assert seen == [("meet", 0), ("forward-level", 1)] and r.states_explored == 2


def _pair_distances(table):
    """Letters needed to merge each pair ``(p, q)``, ``p < q`` (absent: never), by breadth-first search
    backward from the pairs one letter merges (plain Python)."""
    k, n = len(table), len(table[0])
    before, dist, queue = {}, {}, []
    for a in range(k):
        for p in range(n):
            for q in range(p + 1, n):
                x, y = table[a][p], table[a][q]
                if x == y:
                    dist.setdefault((p, q), 1)
                else:
                    before.setdefault((min(x, y), max(x, y)), []).append((p, q))
    queue = sorted(dist)
    for pair in queue:
        for prev in before.get(pair, []):
            if prev not in dist:
                dist[prev] = dist[pair] + 1
                queue.append(prev)
    return dist


def _pruned_forward_levels(table, upper):
    """The forward levels' new sets (before pruning), level by level: images of the kept sets of the
    level before that no kept set equals; a set at depth ``i`` is kept when every pair in it merges
    and its hardest pair needs at most ``upper - 1 - i`` letters (it can still start a word shorter than
    ``upper``), and the number of sets each level drops. Stops when a level keeps nothing."""
    n = len(table[0])
    dist = _pair_distances(table)

    def hardest(s):
        pairs = [(p, q) for p in s for q in s if p < q]
        return max((dist.get(pq, -1) for pq in pairs), default=0) if all(pq in dist for pq in pairs) else -1

    level = [frozenset(range(n))]
    kept_before, grown, dropped = set(level), [], []
    for i in range(1, upper):
        new = []
        for s in level:
            for row in table:
                t = frozenset(row[q] for q in s)
                if t not in kept_before and t not in new:
                    new.append(t)
        grown.append(len(new))
        level = [s for s in new if 0 <= hardest(s) <= upper - 1 - i]
        dropped.append(len(new) - len(level))
        kept_before.update(level)
        if not level:
            break
    return grown, dropped


def test_forward_levels_are_the_images_of_the_sets_that_can_still_start_a_shorter_word():
    """On 60 small random automata (4-9 states, 2-3 letters) searched without the beam (the best word
    known is Eppstein's), each forward level the search reports (``forward-level``: its new sets)
    equals a plain model's: the new images of the sets kept at the level before, where a set at depth
    ``i`` is kept only if its hardest pair (pair distances by breadth-first search) can merge within
    the ``upper - 1 - i`` letters a shorter word would leave. The search grows no forward level after
    one that keeps nothing."""
    pruned = 0
    for seed in range(60):
        rng = np.random.default_rng(seed)
        n, k = int(rng.integers(4, 10)), int(rng.integers(2, 4))
        table = rng.integers(0, n, (k, n)).tolist()
        options, seen = _events(use_beam=False, fast_nodes=None)
        r = shortest_synchronizing_word(SyncAutomaton.from_table(table), time_budget=None, options=options)
        assert r.length == brute(table)
        if r.greedy_length is None:
            continue
        got = [v for e, v in seen if e == "forward-level"]
        want, dropped = _pruned_forward_levels(table, r.greedy_length)
        assert got == want[:len(got)], (seed, got, want)
        pruned += sum(dropped[:len(got)]) > 0
    assert pruned >= 10


def test_stored_depth_first_levels_stay_within_the_memory_cap_too():
    """As test_searches' chunk test (48 x 1,050 bytes of memory: a cap of 20 rows, 2 letters), with
    the deepest level stored instead of generated unstored (``leaf_images=False``), so that every
    level of the depth-first phase is grown by the same halving rule: chunks of 11 sets are never
    expanded whole, no batch passes ``cap / k`` sets, and the answers are the brute-force ones."""
    from tests.kruskal_markov.sync.test_searches import brute_bitmask

    options, seen = _events(dfs_chunk=11, use_beam=False, leaf_images=False)
    memory_mb = 1050 * 48 / 2 ** 20
    for seed in (2, 7):
        seen.clear()
        table = np.random.default_rng(seed).integers(0, 60, size=(2, 60))
        r = shortest_synchronizing_word(SyncAutomaton.from_table(table), time_budget=None, memory_budget_mb=memory_mb,
                                        node_budget=10 ** 8, options=options)
        sizes = [v for e, v in seen if e == "dfs-batch"]
        assert r.method == "bidirectional-bfs+dfs" and r.length == brute_bitmask(table)
        assert sizes and max(sizes) * 2 <= 20 and 11 not in sizes

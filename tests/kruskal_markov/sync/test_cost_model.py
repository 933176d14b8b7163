"""The exact search's cost model (``kruskal_markov.sync.cost_model``): its estimates by value against
figures worked by hand from synchrowords' formulas (Szykula and Zyzik, ESA 2022: ``get_trie_evn``,
``get_dfs_total_factor``, ``calculate_decision``), and on real searches the ``cost-model`` event:
its inputs are the levels a plain breadth-first search grows, its costs the model's on those
inputs, and the search takes the step it chose."""
from __future__ import annotations

import numpy as np
import pytest

from kruskal_markov.sync import (
    ExactSearchOptions,
    SyncAutomaton,
    greedy_synchronizing_word,
    shortest_synchronizing_word,
)
from kruskal_markov.sync.cost_model import Side, StepCosts, dfs_sets, predict_step, retained_share, trie_visits


def test_trie_visits_by_value():
    """``((1 + p) / p + 1 / (q - p q)) m^a`` with ``a = log(1 + p) / log((1 + p) / (1 + p q - q))``:
    at ``p = q = 1/2``, ``a = log2(1.5)`` so ``m^a = 1.5^log2(m)`` and the factor is ``3 + 4 = 7``."""
    assert trie_visits(1, 0.5, 0.5, 10) == 7.0                       # m^a = 1
    assert trie_visits(16, 0.5, 0.5, 100) == pytest.approx(7 * 1.5 ** 4, rel=1e-12)   # 35.4375
    assert trie_visits(64, 0.5, 0.5, 100) == pytest.approx(7 * 1.5 ** 6, rel=1e-12)
    # p = 1/2, q = 1/4: factor 3 + 1 / (1/4 - 1/8) = 11; a = log(1.5) / log(1.5 / 0.875)
    a = np.log(1.5) / np.log(1.5 / 0.875)
    assert trie_visits(8, 0.5, 0.25, 100) == pytest.approx(11 * 8 ** a, rel=1e-12)
    assert trie_visits(8, 0.25, 0.5, 100) != pytest.approx(trie_visits(8, 0.5, 0.25, 100))    # query and stored apart


def test_trie_visits_is_capped_floored_and_clipped():
    """At most ``m n`` nodes (every stored bit); fewer than one stored set counts as one; densities
    outside ``[0.001, 0.999]`` are clipped."""
    assert trie_visits(16, 0.5, 0.5, 2) == 32.0                      # 35.4375 > 16 x 2
    assert trie_visits(16, 0.5, 0.5, 3) == pytest.approx(35.4375, rel=1e-12)   # under 48: not capped
    assert trie_visits(0.25, 0.5, 0.5, 10) == 7.0
    assert trie_visits(4, 0.0, 0.5, 10 ** 6) == trie_visits(4, 1e-3, 0.5, 10 ** 6)
    assert trie_visits(4, 0.5, 1.0, 10 ** 6) == trie_visits(4, 0.5, 1 - 1e-3, 10 ** 6)


def test_dfs_sets_and_retained_share_by_value():
    """``b + b^2 + ... + b^d`` sets below a root; kept / (k x previous), at most 1."""
    assert dfs_sets(2.0, 3) == 14.0 and dfs_sets(3.0, 2) == 12.0
    assert dfs_sets(1.0, 5) == 5.0 and dfs_sets(2.0, 0) == 0.0 and dfs_sets(2.0, -1) == 0.0
    assert retained_share(10, 15, 2) == 0.75 and retained_share(10, 30, 2) == 1.0
    assert retained_share(4, 3, 3) == 0.25 and retained_share(0, 3, 2) == 1.0
    assert retained_share(0, 1, 2) == 1.0                   # no set before: over one, not over k


def test_the_inverse_depth_first_phase_is_chosen_when_it_alone_is_cheapest():
    """F = 16, B = 4 sets of density 1/2, half of each step's sets kept (branching 1), k = 2,
    n = 100, three lengths left; ``ev(16) = 35.4375``, ``c = 512 + 35.4375 = 547.4375``:
    forward step ``512 x 2 x 16 + 200 x 16 + 4 x 35.4375 = 19,725.75``, backward step
    ``512 x 2 x 4 + 4 x 35.4375 = 4,237.75``, each plus ``4 x 2 x c = 4,379.5`` (two lengths left),
    against ``4 x 3 x c = 6,569.25`` for the phase now."""
    s = predict_step(100, 2, Side(16, 0.5, 0.5), Side(4, 0.5, 0.5), remaining=3)
    want = (19725.75, 4237.75, 24105.25, 8617.25, 6569.25)
    got = (s.step_forward, s.step_backward, s.forward_then_idfs, s.backward_then_idfs, s.idfs)
    assert got == pytest.approx(want, rel=1e-12)
    assert s.choice == "idfs" and (s.forward, s.backward, s.remaining) == (Side(16, 0.5, 0.5), Side(4, 0.5, 0.5), 3)
    assert predict_step(100, 2, Side(16, 0.5, 0.5), Side(4, 0.5, 0.5), remaining=3, step_by_cost=True).choice == "idfs"


def test_a_step_is_chosen_by_level_size_or_by_its_cost():
    """Equal levels F = B = 16 (density 1/2, every set kept: branching 2), one length left: forward
    step ``16,384 + 200 x 2 x 16 + 16 ev(32) = 23,634.5`` (``ev(32) = 7 x 1.5^5``), backward step
    ``16,384 + 2 x 16 ev(16) = 17,518``, the phase ``16 x 2 x c = 17,518`` -- exactly the backward
    step (with every set kept ``B D(1) c = SET_COST k B + k B ev``), so not strictly cheapest. The
    rule takes the smaller level, forward on a tie; by cost, the backward step."""
    kw = dict(n=100, k=2, forward=Side(16, 0.5, 1.0), backward=Side(16, 0.5, 1.0), remaining=1)
    s = predict_step(**kw)
    assert (s.step_forward, s.step_backward) == pytest.approx((23634.5, 17518.0), rel=1e-12)
    assert s.backward_then_idfs == s.idfs == s.step_backward and s.forward_then_idfs == s.step_forward
    assert s.choice == "forward" and predict_step(**kw, step_by_cost=True).choice == "backward"
    # F = 4, B = 16: forward step 4,096 + 1,600 + 16 ev(8) = 6,074, backward 16,384 + 32 ev(4) = 16,888
    s = predict_step(100, 2, Side(4, 0.5, 1.0), Side(16, 0.5, 1.0), remaining=1)
    assert (s.step_forward, s.step_backward, s.idfs) == pytest.approx((6074.0, 16888.0, 16888.0), rel=1e-12)
    assert s.choice == "forward" == predict_step(100, 2, Side(4, 0.5, 1.0), Side(16, 0.5, 1.0), 1, True).choice


def _plain_levels(table, forward, depth):
    """The first ``depth`` levels of a plain breadth-first search over sets (no set twice, no empty set): forward
    from all states by images, backward from the singletons a letter merges two states into (the
    only states a shortest word can end in) by preimages."""
    k, n = len(table), len(table[0])
    if forward:
        level = [frozenset(range(n))]
    else:
        level = [frozenset([q]) for q in range(n) if any(table[a].count(q) >= 2 for a in range(k))]
    seen, levels = set(level), [level]
    for _ in range(depth):
        new = []
        for s in level:
            for a in range(k):
                t = frozenset(table[a][p] for p in s) if forward else frozenset(p for p in range(n) if table[a][p] in s)
                if t and t not in seen:
                    seen.add(t)
                    new.append(t)
        levels.append(new)
        level = new
    return levels


def _expected_side(levels, i, n, k):
    sizes = [len(s) for s in levels[i]]
    return Side(len(levels[i]), float(np.mean(sizes)) / n, min(1.0, len(levels[i]) / (k * len(levels[i - 1]))))


@pytest.mark.parametrize("n,seed,step_by_cost", [(50, 3, False), (30, 0, False), (30, 3, False), (50, 3, True), (30, 0, True)])
def test_the_cost_model_event_prices_the_search_s_own_levels_and_the_search_follows_it(n, seed, step_by_cost):
    """Random 2-letter automata (the cost model consulted 2-4 times, every choice taken somewhere;
    with ``step_by_cost`` on 30 states, seed 0, the cheaper step is the larger level's twice):
    the model is consulted only once both newest levels hold over ``n k`` sets, and
    each ``cost-model`` event's inputs are the newest levels of a plain breadth-first search
    (sets, mean density, share kept), its lengths left are the best word known (greedy or beam)
    minus one minus the levels grown, its costs are :func:`predict_step`'s on those inputs, and
    the search's next stage is the step chosen (a level of that side, or the inverse depth-first
    phase and no level after)."""
    table = np.random.default_rng(seed).integers(0, n, (2, n)).tolist()
    seen = []
    r = shortest_synchronizing_word(SyncAutomaton.from_table(table), time_budget=None,
                                    options=ExactSearchOptions(fast_nodes=None, step_by_cost=step_by_cost,
                                                               observe=lambda e, v: seen.append((e, v))))
    count = {e: sum(1 for x, _ in seen if x == e) for e in ("forward-level", "backward-level")}
    fwd, bwd = _plain_levels(table, True, count["forward-level"]), _plain_levels(table, False, count["backward-level"])
    greedy = greedy_synchronizing_word(SyncAutomaton.from_table(table))
    upper = min([len(greedy)] + [v for e, v in seen if e == "beam" and v > 0])
    nf = nb = 0
    choices = []
    for i, (event, value) in enumerate(seen):
        if event in ("forward-level", "backward-level"):
            nf, nb = (nf + 1, nb) if event == "forward-level" else (nf, nb + 1)
            assert value == len((fwd if event == "forward-level" else bwd)[nf if event == "forward-level" else nb])
        if event != "cost-model":
            continue
        assert isinstance(value, StepCosts)
        assert value.forward.sets > n * 2 and value.backward.sets > n * 2      # consulted past n k sets only
        for got, want in ((value.forward, _expected_side(fwd, nf, n, 2)), (value.backward, _expected_side(bwd, nb, n, 2))):
            assert (got.sets, got.density, got.retained) == (want.sets, pytest.approx(want.density, rel=1e-12),
                                                            pytest.approx(want.retained, rel=1e-12))
        assert value.remaining == upper - 1 - nf - nb
        assert value == predict_step(n, 2, value.forward, value.backward, value.remaining, step_by_cost)
        following = [e for e, _ in seen[i + 1:] if e in ("forward-level", "backward-level", "last-level", "inverse-dfs")]
        if value.choice == "idfs":
            assert following == ["inverse-dfs"]
        else:
            assert following[0] in (value.choice + "-level", "last-level")
        choices.append(value.choice)
    assert choices and choices[-1] == "idfs"
    assert r.exact and r.length is not None


def _preimage(table, s, a):
    return frozenset(p for p in range(len(table[0])) if table[a][p] in s)


def _inverse_phase_sets(table, batch, x, depth, leaf_images):
    """Sets the inverse depth-first phase generates below ``batch`` (sets at depth ``x``, grown
    together) when no set it tests contains a forward set, down to ``depth``: the batch's distinct
    non-empty preimages that are not in it, then below those of two states or more (a set of one
    state never starts a shortest word); with ``leaf_images`` the deepest level's ``k`` preimages a
    set, unstored."""
    k = len(table)
    if leaf_images and x + 1 == depth:
        return k * len(batch)
    seen, new = set(batch), []
    for s in batch:
        for a in range(k):
            t = _preimage(table, s, a)
            if t and t not in seen:
                seen.add(t)
                new.append(t)
    kept = [t for t in new if len(t) >= 2]
    return len(new) + (_inverse_phase_sets(table, kept, x + 1, depth, leaf_images) if kept and x + 1 < depth else 0)


@pytest.mark.parametrize("leaf_images", [True, False])
@pytest.mark.parametrize("n,seed", [(50, 2), (50, 3), (40, 3)])
def test_the_inverse_phase_the_cost_model_chooses_grows_each_set_once(n, seed, leaf_images):
    """Random 2-letter automata where the cost model ends the breadth-first search with the inverse
    depth-first phase and that phase proves the beam's word shortest (no hit): the sets counted
    (``states_explored``) are exactly the breadth-first levels' (a plain search) plus, for each set
    of the newest backward level (chunks of one set), one descent over the lengths left -- every
    set grown once, sets of at most one state not grown, the deepest level unstored or stored."""
    table = np.random.default_rng(seed).integers(0, n, (2, n)).tolist()
    seen = []
    r = shortest_synchronizing_word(SyncAutomaton.from_table(table), time_budget=None,
                                    options=ExactSearchOptions(fast_nodes=None, dfs_chunk=1, leaf_images=leaf_images,
                                                               observe=lambda e, v: seen.append((e, v))))
    decisions = [v for e, v in seen if e == "cost-model"]
    assert decisions[-1].choice == "idfs" and [v for e, v in seen if e == "inverse-dfs"] == [0]
    assert r.exact and r.method == "beam+lower-bound"
    count = {e: sum(1 for x, _ in seen if x == e) for e in ("forward-level", "backward-level")}
    fwd, bwd = _plain_levels(table, True, count["forward-level"]), _plain_levels(table, False, count["backward-level"])
    depth = decisions[-1].remaining
    descents = sum(_inverse_phase_sets(table, [s], 0, depth, leaf_images) for s in bwd[-1])
    assert r.states_explored == sum(map(len, fwd)) + sum(map(len, bwd)) + descents

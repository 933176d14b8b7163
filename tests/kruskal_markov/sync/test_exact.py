"""Issue 43: exact shortest reset words with their word -- the inverse beam's first word, the
pair-distance pruning under that bound, and a proven bound equal to the optimum always coming with
the word. Judge: plain breadth-first search over subsets. Budgets in nodes, never seconds."""
from __future__ import annotations

import numpy as np
import pytest

from kruskal_markov import generators
from kruskal_markov.sync import ExactSearchOptions, SyncAutomaton, is_synchronizing_word, shortest_synchronizing_word
from kruskal_markov.sync.beam import beam_width_schedule, inverse_beam_word


def brute(table) -> int | None:
    """Shortest reset length by breadth-first search over the images of the whole state set."""
    t = np.asarray(table)
    k, n = t.shape
    level = [frozenset(range(n))]
    seen = set(level)
    d = 0
    while level:
        if any(len(s) == 1 for s in level):
            return d
        nxt = []
        for s in level:
            for a in range(k):
                u = frozenset(int(t[a, q]) for q in s)
                if u not in seen:
                    seen.add(u)
                    nxt.append(u)
        level, d = nxt, d + 1
    return None


def small_tables(count, seed0=4300):
    for seed in range(seed0, seed0 + count):
        rng = np.random.default_rng(seed)
        n, k = int(rng.integers(5, 15)), int(rng.integers(2, 4))
        yield seed, generators.random_table(n, k, rng)


def test_answers_equal_brute_force_and_exact_means_shortest():
    """60 random automata of 5-14 states, 2-3 letters, unlimited and tight node budgets: every word
    synchronizes, is never shorter than brute force, exact answers have exactly its length and the
    proven lower bound never exceeds it."""
    exact = 0
    for _, table in small_tables(60):
        aut = SyncAutomaton.from_table(table)
        want = brute(table)
        for budget in (None, 30, 200):
            r = shortest_synchronizing_word(aut, time_budget=None, node_budget=budget)
            if want is None:
                assert r.word is None and (r.exact or budget is not None)
                continue
            assert r.word is not None and is_synchronizing_word(aut, r.word) and len(r.word) >= want
            assert r.lower_bound is None or r.lower_bound <= want
            assert r.exact == (r.length == want) or not r.exact
            if r.exact:
                exact += 1
                assert r.length == want
            if budget is None:
                assert r.exact
    assert exact >= 60


def test_the_beam_word_is_proven_shortest_where_the_greedy_word_is_not():
    """Random binary automata of 30-40 states where Eppstein's greedy word is longer than the
    optimum: the inverse beam's word has the shortest length, and the exact search only proves that
    no word is shorter (method ``beam+lower-bound``, ``lower_bound`` equal to the length, the greedy
    length kept); ``_exact_search`` given that bound returns 'upper' with it. (The small-search
    fast path, which answers these before the beam runs, is switched off.)"""
    from kruskal_markov._subsets import as_start
    from kruskal_markov.sync import greedy_synchronizing_word
    from kruskal_markov.sync.exact import _exact_search

    beam_first = ExactSearchOptions(fast_nodes=None)

    checked = 0
    for seed in range(4310, 4318):
        n = 30 + (seed % 3) * 5
        table = generators.random_table(n, 2, seed)
        aut = SyncAutomaton.from_table(table)
        want = brute(table)
        greedy = greedy_synchronizing_word(aut)
        if want is None or len(greedy) == want:
            continue
        r = shortest_synchronizing_word(aut, time_budget=None, options=beam_first)
        assert r.exact and r.length == want == len(r.word) == r.lower_bound and is_synchronizing_word(aut, r.word)
        if r.method == "beam+lower-bound":
            assert r.greedy_length == len(greedy) > want
            got = _exact_search(aut, as_start(aut, None), None, 64.0, None, want)
            assert got[0] is None and got[1] == "upper" and got[3] == want
            checked += 1
    assert checked >= 3


@pytest.mark.parametrize("seed", [4320, 4321, 4322])
def test_inverse_beam_of_unbounded_width_is_a_shortest_word(seed):
    """With a width above the number of subsets the inverse beam is a full inverse breadth-first
    search: its first word is a shortest one; a narrow beam's word synchronizes and is no shorter."""
    table = generators.random_table(10, 2, seed)
    aut = SyncAutomaton.from_table(table)
    want = brute(table)
    start = aut.bits(range(10))
    wide = inverse_beam_word(aut, start, 2 ** 11)
    assert wide is not None and len(wide) == want and is_synchronizing_word(aut, wide)
    narrow = inverse_beam_word(aut, start, 2)
    assert narrow is None or (len(narrow) >= want and is_synchronizing_word(aut, narrow))
    assert inverse_beam_word(aut, start, 2 ** 11, max_length=want - 1) is None
    assert inverse_beam_word(aut, start, 2 ** 11, node_budget=1) in (None, wide)


def test_beam_width_schedule_follows_the_dynamic_rule():
    """``n log2 n`` without a length; 1% of ``2 k^floor((L+1)/2) / L`` clamped to [n log2 n, n^2 log2 n]."""
    assert beam_width_schedule(256, 2, None) == 256 * 8
    assert beam_width_schedule(256, 2, 10) == 256 * 8                    # 2 * 2^5 / 1000: tiny
    assert beam_width_schedule(16, 8, 15) == 16 * 16 * 4                  # clamped above
    assert beam_width_schedule(100, 8, 14) == round(2 * 8 ** 7 * 0.01 / 14)       # 2,996, as synchrowords logs


def test_cerny_automata_are_exact_with_the_cerny_length():
    for n in (4, 7, 10):
        r = shortest_synchronizing_word(generators.cerny_automaton(n), time_budget=None)
        assert r.exact and r.length == (n - 1) ** 2 and is_synchronizing_word(generators.cerny_automaton(n), r.word)


def test_rarest_member_meet_test_agrees_with_brute_force():
    """:class:`RarestMeetIndex` on 300 random pairs of forward/backward bitset lists (2-149 states,
    forward rows from a random offset, candidate chunks of one 64-row word or a whole group):
    it reports a pair exactly when some forward row lies inside some backward row, and the
    pair it reports does."""
    from kruskal_markov import _sync_kernels as kern

    rng = np.random.default_rng(4330)
    outcomes = set()
    for _ in range(300):
        n = int(rng.integers(2, 150))
        W = (n + 63) // 64
        nf, nb = int(rng.integers(1, 300)), int(rng.integers(0, 400))
        F = rng.random((nf, n)) < rng.uniform(0.02, 0.3)
        B = rng.random((nb, n)) < rng.uniform(0.3, 0.9)
        F[F.sum(axis=1) == 0, 0] = True

        def pack(M):
            out = np.zeros((M.shape[0], W), dtype=np.uint64)
            for i, row in enumerate(M):
                for q in np.flatnonzero(row):
                    out[i, q >> 6] |= np.uint64(1) << np.uint64(q & 63)
            return out

        index = kern.RarestMeetIndex(pack(B), 0, nb, n, max_bytes=int(rng.choice([8 * n, 10 ** 6])))
        lo = int(rng.integers(0, nf))
        f, b = index.query(pack(F), lo, nf)
        exists = nb > 0 and bool(np.any((F[lo:, None, :] & ~B[None, :, :]).sum(axis=2) == 0))
        assert (f >= 0) == exists
        outcomes.add(exists)
        if f >= 0:
            assert lo <= f < nf and not np.any(F[f] & ~B[b])
    assert outcomes == {True, False}


def test_subset_dominance_check_agrees_with_brute_force():
    """``dominated_in_store`` on 150 random stores of distinct bitsets: a row is flagged exactly when
    a strictly larger row of the candidate range contains it."""
    from kruskal_markov import _sync_kernels as kern

    rng = np.random.default_rng(4340)
    flagged = 0
    for _ in range(150):
        n = int(rng.integers(2, 130))
        W = (n + 63) // 64
        M = rng.random((int(rng.integers(1, 200)), n)) < rng.uniform(0.05, 0.6)
        M[M.sum(axis=1) == 0, 0] = True
        M = np.unique(M, axis=0)
        rng.shuffle(M)
        cnt = M.shape[0]
        st = np.zeros((cnt, W), dtype=np.uint64)
        for i, row in enumerate(M):
            for q in np.flatnonzero(row):
                st[i, q >> 6] |= np.uint64(1) << np.uint64(q & 63)
        ylo, lo = int(rng.integers(0, cnt)), int(rng.integers(0, cnt))
        got = kern.dominated_in_store(st, ylo, cnt, lo, cnt, n, max_bytes=int(rng.choice([8 * n, 10 ** 6])))
        want = [any((M[j] >= M[i]).all() and M[j].sum() > M[i].sum() for j in range(ylo, cnt)) for i in range(lo, cnt)]
        assert got.tolist() == want
        flagged += sum(want)
    assert flagged > 0


def test_backward_dominance_keeps_the_answers():
    """With the (off by default) backward subset dominance switched on, the shortest lengths on 40
    small random automata are still the brute-force ones."""
    options = ExactSearchOptions(backward_dominance=True, use_beam=False)
    for _, table in small_tables(40, 4350):
        aut = SyncAutomaton.from_table(table)
        r = shortest_synchronizing_word(aut, time_budget=None, options=options)
        want = brute(table)
        assert r.length == want and (want is None or is_synchronizing_word(aut, r.word))


def test_small_automata_are_answered_before_the_beam():
    """The small-search fast path: an exact search capped at ``fast_nodes`` sets below the greedy
    word answers small automata without the beam (method ``bidirectional-bfs`` or
    ``greedy-eppstein+lower-bound``, the brute-force length; the search's stages observed through
    ``ExactSearchOptions.observe``); past the cap the beam and the full search answer the same
    length, with the fast path's sets counted in ``states_explored``."""
    events = []

    def observe(event, value):
        events.append(event)
    for seed in range(4330, 4336):
        table = generators.random_table(12 + seed % 5, 2 + seed % 2, seed)
        aut = SyncAutomaton.from_table(table)
        want = brute(table)
        r = shortest_synchronizing_word(aut, time_budget=None, options=ExactSearchOptions(observe=observe))
        assert r.exact and r.length == want and (want is None or is_synchronizing_word(aut, r.word))
        if want is not None:
            assert r.method in ("bidirectional-bfs", "greedy-eppstein+lower-bound")
    assert "fast-path" in events and "beam" not in events
    table = generators.random_table(30, 2, 4340)
    aut = SyncAutomaton.from_table(table)
    capped = shortest_synchronizing_word(aut, time_budget=None,     # every fast search stops at its cap
                                         options=ExactSearchOptions(fast_nodes=2, observe=observe))
    assert "beam" in events and capped.exact and capped.length == brute(table)
    plain = shortest_synchronizing_word(aut, time_budget=None, options=ExactSearchOptions(fast_nodes=None))
    assert plain.length == capped.length and capped.states_explored > plain.states_explored


@pytest.mark.parametrize("deterministic", [True, False])
def test_level_images_are_the_images_and_preimages_whatever_the_split(deterministic):
    """The unhashed level kernel (the last level of a search): row ``(i - lo) k + a`` is the image,
    or the preimage, of set ``i`` under letter ``a``, judged by plain Python on random sets of a
    random automaton (deterministic, and set-valued: a preimage holds the states whose every
    successor is in the set); the same on one thread, split over threads (forced on) and, for the
    deterministic one, by byte tables (``SyncAutomaton.step_table``)."""
    from kruskal_markov import _sync_kernels as _k
    from kruskal_markov.sync import support_automaton
    from tests.kruskal_markov.sync.test_searches import model_from_support

    rng = np.random.default_rng(4370)
    n, k = 70, 3
    if deterministic:
        succ = [[{int(x)} for x in row] for row in generators.random_table(n, k, rng)]
        aut = SyncAutomaton.from_table([[next(iter(s)) for s in row] for row in succ])
    else:
        succ = [[set(rng.choice(n, size=int(rng.integers(1, 3)), replace=False).tolist()) for _ in range(n)]
                for _ in range(k)]
        aut = support_automaton(model_from_support([[frozenset(s) for s in row] for row in succ]))
    assert aut.deterministic == deterministic
    sets = [set(np.flatnonzero(rng.random(n) < rng.uniform(0.05, 0.6)).tolist()) for _ in range(40)]
    rows = np.array([aut.bits(sorted(s)) for s in sets])
    for forward in (True, False):
        one = _k.level_images(rows, 2, 38, aut.delta, aut.sup, aut.deterministic, forward, *aut.inverse, tasks=1)
        split = _k.level_images(rows, 2, 38, aut.delta, aut.sup, aut.deterministic, forward, *aut.inverse, tasks=3,
                                min_parallel=1)
        tables = _k.level_images(rows, 2, 38, aut.delta, aut.step_table(forward), aut.deterministic, forward,
                                 *aut.inverse, tasks=1)     # byte tables (deterministic only)
        assert (one == split).all() and (one == tables).all()
        assert (aut.step_table(forward) is not aut.sup) == deterministic
        for i in range(2, 38):
            for a in range(k):
                want = set().union(*(succ[a][q] for q in sets[i])) if forward else \
                    {q for q in range(n) if succ[a][q] <= sets[i]}
                assert set(aut.states_of(one[(i - 2) * k + a])) == want


def test_a_large_level_expanded_in_two_passes_is_the_one_pass_level():
    """Levels of 16,384 sets or more are expanded by computing their images on both cores and
    inserting them on one: the stored rows, parents and letters are those of the one-pass kernel
    (both directions, random 3-letter automaton of 90 states, a forward level of 20,000 sets)."""
    from kruskal_markov import _sync_kernels as _k
    from kruskal_markov._subsets import SubsetStore

    aut = SyncAutomaton.from_table(generators.random_table(90, 3, 4371))
    rng = np.random.default_rng(4371)
    roots = [aut.bits(np.flatnonzero(rng.random(90) < 0.3)) for _ in range(20_000)]
    for forward in (True, False):
        two, one = SubsetStore(aut.n_words, 1024, 10 ** 6), SubsetStore(aut.n_words, 1024, 10 ** 6)
        two.add_roots(roots)
        one.add_roots(roots)
        assert two.expand(aut, forward) > 0 and two.levels[-2][1] - two.levels[-2][0] >= 2 * _k._IMAGES_PAR_MIN
        lo, hi = one.levels[-1]
        one.ensure(one.count + (hi - lo) * aut.k)
        new = _k.expand_level(one.rows, one.count, lo, hi, aut.delta, aut.sup, True, forward, one.table, one.parent,
                              one.letter, one.rows.shape[0], *aut.inverse)
        assert new == two.count
        for arr in ("rows", "parent", "letter"):
            assert (getattr(one, arr)[:new] == getattr(two, arr)[:new]).all()


def test_the_answer_and_its_work_do_not_depend_on_the_threads():
    """``ExactSearchOptions(parallel=...)`` only splits kernels over threads: on random 8-letter
    automata of 60 states (93,539 and 291,101 subsets, so the meet test's trie walks pass their
    split threshold of 8,192 queries), with the beam off (the search must find the word itself),
    the word's length, ``exact`` and the subsets generated are the same with and without it."""
    for seed in (4372, 4373):
        aut = SyncAutomaton.from_table(generators.random_table(60, 8, seed))
        got = [shortest_synchronizing_word(aut, time_budget=None, node_budget=10 ** 8,
                                           options=ExactSearchOptions(use_beam=False, parallel=p))
               for p in (False, True)]
        assert got[0].exact and got[1].exact and is_synchronizing_word(aut, got[1].word)
        assert (got[0].length, got[0].states_explored) == (got[1].length, got[1].states_explored)


def test_options_are_checked():
    with pytest.raises(ValueError, match="last_side"):
        ExactSearchOptions(last_side="sideways")
    with pytest.raises(ValueError, match="dfs_chunk"):
        ExactSearchOptions(dfs_chunk=0)
    with pytest.raises(ValueError, match="fast_nodes"):
        ExactSearchOptions(fast_nodes=-1)
    assert ExactSearchOptions(parallel=False).resolved().tasks == 1
    assert ExactSearchOptions(parallel=True).resolved().tasks == 8


def test_the_thread_rule_depends_on_the_cores_only():
    """The default (``parallel=None``) splits kernels over threads exactly when the process may run
    on two cores or more (and Numba has two threads): the same inputs give the same choice, and an
    explicit choice is kept whatever the cores."""
    import numba

    from kruskal_markov.sync.options import default_parallel

    assert default_parallel(cores=1, threads=8) is False
    assert default_parallel(cores=2, threads=1) is False
    assert default_parallel(cores=2, threads=2) is True
    many = numba.get_num_threads() >= 2
    assert ExactSearchOptions().resolved(cores=1).parallel is False
    assert ExactSearchOptions().resolved(cores=4).parallel is many
    assert ExactSearchOptions(parallel=True).resolved(cores=1).parallel is True
    assert ExactSearchOptions(parallel=False).resolved(cores=4).parallel is False


def test_the_result_says_how_many_threads_the_search_used():
    """``SyncResult.threads`` (and the ``threads`` key of ``kruskal sync``'s JSON) reports the
    choice: 1 with ``parallel=False``, Numba's thread count with ``parallel=True``; the answer is
    the same."""
    import numba

    aut = SyncAutomaton.from_table(generators.random_table(30, 3, 4374))
    one = shortest_synchronizing_word(aut, time_budget=None, options=ExactSearchOptions(parallel=False))
    split = shortest_synchronizing_word(aut, time_budget=None, options=ExactSearchOptions(parallel=True))
    assert one.threads == 1 and one.as_dict()["threads"] == 1
    assert split.threads == numba.get_num_threads()
    assert (one.word, one.exact, one.states_explored) == (split.word, split.exact, split.states_explored)

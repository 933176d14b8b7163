"""Paper-level answers with their intervals: every interval holds its point estimate, the terms vanish
where they should, and the structural range is the entropy ball's on the model's own distributions."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from kruskal_markov.answers import answer_intervals, plan_success_interval
from kruskal_markov.generators import cerny_model
from kruskal_markov.model import TransitionModel


def _counted_model(seed=3, n=12, cells=4):
    """A random stochastic model whose rows are counts / 20 (so it carries a posterior)."""
    rng = np.random.default_rng(seed)
    mats, extras = [], {}
    for a in range(3):
        c = np.zeros((n, n))
        for i in range(n):
            tg = rng.choice(n, 2, replace=False)
            c[i, tg] = rng.multinomial(20, [0.8, 0.2])
        m = sp.csr_matrix(c)
        extras[f"counts_{a}"] = m.data.astype(np.int64)
        mats.append(sp.csr_matrix((m.data / 20.0, m.indices, m.indptr), shape=(n, n)))
    return TransitionModel(["a", "b", "c"], mats, initial=np.full(n, 1.0 / n), partition=np.arange(n) % cells,
                           n_cells=cells, extras=extras)


def _intervals(d):
    for k, v in d.items():
        if k == "settings":
            continue
        for name in ("mc_ci95", "posterior_ci90", "structural_range", "model_ci90"):
            if v.get(name) is not None and None not in v[name]:
                yield k, name, v["value"], v[name]


@pytest.mark.parametrize("delta", [0.0, 0.105, 0.5])
def test_every_interval_contains_its_point_estimate(delta):
    m = _counted_model()
    out = answer_intervals(m, seed=1, count=300, length=20, epsilon=1e-3, runs=60, max_steps=200, draws=8,
                           draw_count=200, structural_delta=delta, structural_sequences=40)
    seen = list(_intervals(out))
    assert {k for k, *_ in seen} == {"converging_share", "mean_entropy_10", "mean_entropy_20", "random_tilts"}
    for k, name, value, (lo, hi) in seen:
        assert lo <= value <= hi, (k, name, value, lo, hi)
    for k, _, value, _ in seen:
        post, struct, model = out[k]["posterior_ci90"], out[k]["structural_range"], out[k]["model_ci90"]
        # the model interval is the posterior interval widened by the structural range, end to end
        assert model[0] == pytest.approx(post[0] - (value - struct[0]))
        assert model[1] == pytest.approx(post[1] + (struct[1] - value))


def test_zero_structural_error_leaves_the_posterior_interval():
    m = _counted_model()
    out = answer_intervals(m, seed=1, count=300, length=20, epsilon=1e-3, draws=8, draw_count=200,
                           structural_delta=0.0, structural_sequences=40)
    for k in ("converging_share", "mean_entropy_10", "mean_entropy_20"):
        v = out[k]
        assert v["structural_range"] == [v["value"], v["value"]]
        assert v["model_ci90"] == v["posterior_ci90"]
    wide = answer_intervals(m, seed=1, count=300, length=20, epsilon=1e-3, draws=8, draw_count=200,
                            structural_delta=0.3, structural_sequences=40)
    # a mixed distribution's entropy ball is not a point: the structural range of the mean entropy opens
    v = wide["mean_entropy_10"]
    assert v["structural_range"][1] > v["value"] + 1e-3 and v["structural_range"][0] < v["value"] - 1e-3


def test_a_model_without_counts_has_no_posterior_and_a_synchronized_one_no_structural_range():
    m = cerny_model(2)           # deterministic and synchronizing, no counts
    out = answer_intervals(m, seed=0, count=200, length=50, epsilon=1e-9, runs=50, max_steps=500, draws=5,
                           structural_sequences=30)
    assert out["settings"]["draws"] == 0
    assert all(out[k]["posterior_ci90"] is None for k in ("converging_share", "mean_entropy_10", "random_tilts"))
    # Černý C_2 synchronizes a random 50-letter sequence unless it is all one letter (2^-49)
    assert out["converging_share"]["value"] == 1.0
    assert out["converging_share"]["structural_range"] == [1.0, 1.0]
    assert out["mean_entropy_50"]["structural_range"] == [0.0, 0.0]


def test_plan_success_interval():
    m = _counted_model()
    out = plan_success_interval(m, [0, 1, 2], 0.6, draws=8, structural_delta=0.2)
    assert out["structural_range"][0] < 0.6 < out["structural_range"][1]
    assert out["model_ci90"][0] <= out["posterior_ci90"][0] <= 0.6 <= out["posterior_ci90"][1] <= out["model_ci90"][1]
    none = plan_success_interval(m, [0, 1, 2], 0.6, draws=0, structural_delta=0.0)
    assert none["posterior_ci90"] is None and none["model_ci90"] == [0.6, 0.6]


def _range_by_bisection(p, d):
    """An independent computation of the TV ball's entropy range (bisection on the clipping levels)."""
    p = np.asarray(p, float) / np.sum(p)
    h = lambda q: float(-(q[q > 0] * np.log2(q[q > 0])).sum())     # noqa: E731
    if d <= 0:
        return h(p), h(p)
    lo_u, hi_u = 0.0, 1.0
    for _ in range(200):
        u = 0.5 * (lo_u + hi_u)
        lo_u, hi_u = (u, hi_u) if np.clip(p - u, 0, None).sum() > d else (lo_u, u)
    lo_l, hi_l = 0.0, 1.0
    for _ in range(200):
        lv = 0.5 * (lo_l + hi_l)
        lo_l, hi_l = (lo_l, lv) if np.clip(lv - p, 0, None).sum() > d else (lv, hi_l)
    top = np.log2(len(p)) if lo_l >= hi_u else h(np.clip(p, lo_l, hi_u))
    s = np.sort(p)
    room = min(d, 1 - s[-1])
    q = s.copy()
    q[-1] += room
    for i in range(len(s) - 1):
        t = min(q[i], room)
        q[i] -= t
        room -= t
    return min(h(q), h(p)), max(top, h(p))


def test_answer_values_match_an_independent_computation():
    """Every figure of answer_intervals recomputed from its definition with the same random streams:
    the ensemble, Wilson, the Monte Carlo sd on the structural subsample, the posterior quantiles over
    draws [seed, 7, i] on the first draw_count sequences, and the structural shift of the mean entropy
    (the TV ball's range by bisection, not the Numba kernel)."""
    from kruskal_markov.answers import wilson_interval
    from kruskal_markov.ensemble import random_sequences, run_ensemble
    from kruskal_markov.entropy import entropy_trajectory
    from kruskal_markov.posterior import resample_model

    m = _counted_model()
    seed, count, length, delta, sub, draws, dc = 4, 400, 20, 0.2, 25, 6, 150
    out = answer_intervals(m, seed=seed, count=count, length=length, epsilon=1e-3, draws=draws, draw_count=dc,
                           structural_delta=delta, structural_sequences=sub)
    ens = run_ensemble(m, count, length, seed=seed, epsilon=1e-3)
    share = ens.converged / count
    assert out["converging_share"]["value"] == share
    assert out["converging_share"]["mc_ci95"] == pytest.approx(list(wilson_interval(ens.converged, count)))
    seqs = random_sequences(m.n_actions, sub, length, seed=[seed, 8])
    h, hmin, hmax = [], [], []
    for s in seqs:
        tr = entropy_trajectory(m, s, return_distributions=True)
        cells = np.stack([np.bincount(m.partition, weights=p, minlength=m.n_cells) for p in tr.distributions])
        rows = [(_range_by_bisection(c, delta * (1 - c.max() / c.sum())), tr.entropy_bits[k])
                for k, c in enumerate(cells)]
        h.append([e for _, e in rows])
        hmin.append([r[0] for r, _ in rows])
        hmax.append([r[1] for r, _ in rows])
    h, hmin, hmax = map(np.asarray, (h, hmin, hmax))
    base = run_ensemble(m, dc, length, seed=seed, epsilon=1e-3)
    diffs = {10: [], 20: []}
    for i in range(draws):
        d = run_ensemble(resample_model(m, np.random.default_rng([seed, 7, i])), dc, length, seed=seed, epsilon=1e-3)
        for t in diffs:
            diffs[t].append(d.mean[t] - base.mean[t])
    for t in (10, 20):
        v = out[f"mean_entropy_{t}"]
        assert v["value"] == pytest.approx(ens.mean[t])
        half = 1.96 * h[:, t].std(ddof=1) / np.sqrt(count)
        assert v["mc_ci95"] == pytest.approx([ens.mean[t] - half, ens.mean[t] + half])
        q = np.quantile(diffs[t], [0.05, 0.95])
        assert v["posterior_ci90"] == pytest.approx([min(ens.mean[t], ens.mean[t] + q[0]),
                                                     max(ens.mean[t], ens.mean[t] + q[1])])
        lo = max(0.0, ens.mean[t] + np.mean(hmin[:, t] - h[:, t]))
        hi = ens.mean[t] + np.mean(hmax[:, t] - h[:, t])
        assert v["structural_range"] == pytest.approx([lo, hi], abs=1e-9)
        assert hi - lo > 0.05
    assert out["settings"]["draw_count"] == dc and out["settings"]["structural_delta"] == delta


def _merging_model():
    """8 states on 4 cells: ``a`` halves the state (i -> i // 2, sampled 20 times), ``b`` moves it one on
    (19 of 20 samples; 1 stays): random words converge and spread again."""
    n = 8
    ca = sp.csr_matrix((np.full(n, 20.0), (np.arange(n), np.arange(n) // 2)), shape=(n, n))
    cb = sp.csr_matrix((np.r_[np.full(n, 19.0), np.ones(n)], (np.r_[np.arange(n), np.arange(n)],
                                                             np.r_[(np.arange(n) + 1) % n, np.arange(n)])), shape=(n, n))
    mats, extras = [], {}
    for a, c in enumerate((ca, cb)):
        c.sort_indices()
        extras[f"counts_{a}"] = c.data.astype(np.int64)
        tot = np.asarray(c.sum(1)).ravel()
        mats.append(sp.csr_matrix((c.data / np.repeat(tot, np.diff(c.indptr)), c.indices, c.indptr), shape=(n, n)))
    return TransitionModel(["a", "b"], mats, initial=np.full(n, 1.0 / n), partition=np.arange(n) % 4, n_cells=4,
                           extras=extras)


def test_share_and_random_tilts_structural_ranges_match_an_independent_computation():
    from kruskal_markov.convergence import monte_carlo_entropy_tilts
    from kruskal_markov.ensemble import random_sequences, run_ensemble
    from kruskal_markov.entropy import entropy_trajectory

    m = _merging_model()
    seed, count, length, delta, sub, runs, cap, eps = 2, 300, 12, 1.0, 15, 40, 40, 0.3
    out = answer_intervals(m, seed=seed, count=count, length=length, epsilon=eps, runs=runs, max_steps=cap, draws=0,
                           structural_delta=delta, structural_sequences=sub)
    ens = run_ensemble(m, count, length, seed=seed, epsilon=eps)
    share = ens.converged / count
    assert 0.05 < share < 0.95
    seqs = random_sequences(2, sub, cap, seed=[seed, 8])           # the subsample runs max(length, cap) tilts
    h, lo, hi = [], [], []
    for s in seqs:
        tr = entropy_trajectory(m, s, return_distributions=True)
        rows = []
        for p in tr.distributions:
            c = np.bincount(m.partition, weights=p, minlength=4)
            rows.append(_range_by_bisection(c, delta * (1 - c.max() / c.sum())))
        h.append(tr.entropy_bits)
        lo.append([r[0] for r in rows])
        hi.append([r[1] for r in rows])
    h, lo, hi = map(np.asarray, (h, lo, hi))
    conv = lambda a: (a[:, :length + 1] <= eps).any(1).mean()      # noqa: E731
    assert out["converging_share"]["structural_range"] == pytest.approx(
        [max(0.0, share + conv(hi) - conv(h)), min(1.0, share + conv(lo) - conv(h))])

    def first(a):
        f = np.argmax(a <= eps, axis=1).astype(float)
        f[~(a <= eps).any(1)] = cap
        return f
    t = monte_carlo_entropy_tilts(m, eps, runs=runs, seed=[seed, 5], max_steps=cap)
    v = out["random_tilts"]
    assert v["value"] == pytest.approx(t["mean"] if t["mean"] is not None else t["lower"])
    assert v["censored"] == t["censored"]
    assert v["structural_range"] == pytest.approx([max(0.0, v["value"] + np.mean(first(lo) - first(h))),
                                                   v["value"] + np.mean(first(hi) - first(h))])
    # at a threshold of 0.3 bits and delta 1 the ball moves both answers (checked: not zero-width)
    assert v["structural_range"][0] < v["value"] and out["converging_share"]["structural_range"][1] > share


def test_posterior_draws_on_a_subsample_give_the_same_interval():
    """Common random numbers make a draw's answer a difference between models: on 200 sequences (the
    default) the posterior interval of the mean entropies matches the one on 2,000 to within 15% of
    its width (measured: at most 0.004 bits on a width of 0.047)."""
    m = _counted_model(n=40, cells=8)
    small, big = (answer_intervals(m, seed=1, count=2000, length=20, draws=20, structural_delta=0,
                                   **({} if dc is None else {"draw_count": dc}),
                                   structural_sequences=50) for dc in (None, 2000))
    assert small["settings"]["draw_count"] == 200 and big["settings"]["draw_count"] == 2000
    for k in ("mean_entropy_10", "mean_entropy_20"):
        a, b = small[k]["posterior_ci90"], big[k]["posterior_ci90"]
        width = b[1] - b[0]
        assert width > 0.02
        assert abs(a[0] - b[0]) < 0.15 * width and abs(a[1] - b[1]) < 0.15 * width


def test_plan_success_interval_by_value_against_its_definition():
    """The plan's interval recomputed from its definition: the final report-cell distribution after the
    word, the posterior 5-95% quantiles of its most likely cell's probability over the default 20
    draws [seed, 7, i] (shifted onto ``success``, clipped to [0, 1]), and the structural range
    ``success -+ delta (1 - max(c))``; an explicit final cell changes which cell the draws follow."""
    from kruskal_markov.entropy import entropy_trajectory
    from kruskal_markov.posterior import resample_model

    m = _counted_model()
    word, seed, delta = [0, 1, 2], 2, 0.2

    def final(mm):
        p = entropy_trajectory(mm, word, return_distributions=True).distributions[-1]
        return np.bincount(m.partition, weights=p, minlength=m.n_cells)

    c = final(m)
    draws = [final(resample_model(m, np.random.default_rng([seed, 7, i]))) for i in range(20)]
    for cell in (int(np.argmax(c)), int(np.argmin(c))):
        success = float(c[cell])
        out = plan_success_interval(m, word, success, seed=seed, structural_delta=delta,
                                    final_cell=None if cell == int(np.argmax(c)) else cell)
        q = np.quantile([d[cell] - c[cell] for d in draws], [0.05, 0.95])
        post = [max(0.0, success + q[0]), min(1.0, success + q[1])]
        s = delta * (1 - c.max() / c.sum())
        assert 0 < success + q[1] < 1 and 0 < success - s and success + s < 1
        assert out["value"] == success
        assert out["posterior_ci90"] == pytest.approx([min(post[0], success), max(post[1], success)])
        assert out["structural_range"] == pytest.approx([success - s, success + s])
        lo, hi = out["posterior_ci90"]
        assert out["model_ci90"] == pytest.approx([max(0.0, lo - s), min(1.0, hi + s)])


def test_mean_entropies_are_reported_at_the_tilts_within_the_length():
    """Mean entropies at tilts 10, 20 and 50, each only when the sequences are that long."""
    m = _counted_model()
    keys = {length: {k for k in answer_intervals(m, seed=0, count=50, length=length, draws=0, structural_delta=0,
                                                 structural_sequences=5) if k.startswith("mean_entropy")}
            for length in (9, 10, 19, 20, 49, 50)}
    assert keys == {9: set(), 10: {"mean_entropy_10"}, 19: {"mean_entropy_10"},
                    20: {"mean_entropy_10", "mean_entropy_20"}, 49: {"mean_entropy_10", "mean_entropy_20"},
                    50: {"mean_entropy_10", "mean_entropy_20", "mean_entropy_50"}}


@pytest.mark.parametrize("seed, weights", [([3, 1], None), (7, [0.7, 0.3])])
def test_every_figure_with_runs_and_draws_from_its_streams(seed, weights):
    """Every figure with Monte Carlo runs, posterior draws and the structural term, recomputed from its
    definition and documented streams: the ensemble seeded ``seed``, the random tilts ``[*seed, 5]``,
    the posterior draws ``[sum(seed), 7, i]`` (each draw's answers minus the model's on the first
    ``draw_count`` sequences and the same runs), the structural subsample ``[sum(seed), 8]``, all drawn
    with the action ``weights``. A seed given as a sequence ([3, 1]) and a scalar one with weights."""
    from kruskal_markov.convergence import monte_carlo_entropy_tilts
    from kruskal_markov.ensemble import random_sequences, run_ensemble
    from kruskal_markov.entropy import entropy_trajectory
    from kruskal_markov.posterior import resample_model

    m = _merging_model()           # at 0.3 bits its random tilts converge (7.6 on average), so they vary by draw
    count, length, eps, runs, cap, draws, dc, delta, sub = 200, 20, 0.3, 30, 60, 4, 100, 0.2, 12
    tilt_seed, s_sum = [*np.atleast_1d(seed).tolist(), 5], int(np.sum(seed))
    out = answer_intervals(m, seed=seed, count=count, length=length, epsilon=eps, runs=runs, max_steps=cap,
                           draws=draws, draw_count=dc, structural_delta=delta, structural_sequences=sub,
                           weights=weights)
    ens = run_ensemble(m, count, length, seed=seed, epsilon=eps, weights=weights)
    share = ens.converged / count
    assert out["converging_share"]["value"] == share
    t = monte_carlo_entropy_tilts(m, eps, weights, runs=runs, seed=tilt_seed, max_steps=cap)
    tilts = t["mean"]
    assert t["censored"] == 0 and out["random_tilts"]["value"] == pytest.approx(tilts)
    assert out["random_tilts"]["mc_ci95"] == pytest.approx(list(t["ci95"]))

    def figures(mm):
        e = run_ensemble(mm, dc, length, seed=seed, epsilon=eps, weights=weights)
        r = monte_carlo_entropy_tilts(mm, eps, weights, runs=runs, seed=tilt_seed, max_steps=cap)
        return {"s": e.converged / dc, 10: e.mean[10], 20: e.mean[20],
                "t": r["mean"] if r["mean"] is not None else r["lower"]}

    base = figures(m)
    diffs = [{k: v - base[k] for k, v in figures(resample_model(m, np.random.default_rng([s_sum, 7, i]))).items()}
             for i in range(draws)]
    point = {"s": share, 10: ens.mean[10], 20: ens.mean[20], "t": tilts}
    for k, key in (("s", "converging_share"), (10, "mean_entropy_10"), (20, "mean_entropy_20"), ("t", "random_tilts")):
        q = np.quantile([d[k] for d in diffs], [0.05, 0.95])
        assert out[key]["posterior_ci90"] == pytest.approx([min(point[k], point[k] + q[0]),
                                                            max(point[k], point[k] + q[1])]), key
    h, lo, hi = [], [], []
    for sq in random_sequences(m.n_actions, sub, cap, seed=[s_sum, 8], weights=weights):
        tr = entropy_trajectory(m, sq[:length], return_distributions=True)
        rows = []
        for p in tr.distributions:
            c = np.bincount(m.partition, weights=p, minlength=m.n_cells)
            rows.append(_range_by_bisection(c, delta * (1 - c.max() / c.sum())))
        h.append(tr.entropy_bits)
        lo.append([r[0] for r in rows])
        hi.append([r[1] for r in rows])
    h, lo, hi = map(np.asarray, (h, lo, hi))
    for k in (10, 20):
        assert out[f"mean_entropy_{k}"]["structural_range"] == pytest.approx(
            [max(0.0, ens.mean[k] + np.mean(lo[:, k] - h[:, k])), ens.mean[k] + np.mean(hi[:, k] - h[:, k])], abs=1e-9)
    assert out["settings"]["structural_source"] == "given" and out["settings"]["draws"] == draws


def test_the_converging_shares_structural_range_where_neither_end_is_clipped():
    """8 tilts at 0.3 bits and delta 0.5 on the merging model: 62% of sequences converge and the ball
    moves that share both ways, within (0, 1); recomputed on the subsample [seed, 8] by bisection."""
    from kruskal_markov.ensemble import random_sequences, run_ensemble
    from kruskal_markov.entropy import entropy_trajectory

    m = _merging_model()
    seed, count, length, eps, delta, sub = 2, 300, 8, 0.3, 0.5, 15
    out = answer_intervals(m, seed=seed, count=count, length=length, epsilon=eps, draws=0, structural_delta=delta,
                           structural_sequences=sub)
    share = run_ensemble(m, count, length, seed=seed, epsilon=eps).converged / count
    h, lo, hi = [], [], []
    for sq in random_sequences(2, sub, length, seed=[seed, 8]):
        tr = entropy_trajectory(m, sq, return_distributions=True)
        rows = [_range_by_bisection(c, delta * (1 - c.max() / c.sum()))
                for c in (np.bincount(m.partition, weights=p, minlength=4) for p in tr.distributions)]
        h.append(tr.entropy_bits)
        lo.append([r[0] for r in rows])
        hi.append([r[1] for r in rows])
    conv = lambda a: (np.asarray(a) <= eps).any(1).mean()      # noqa: E731
    want = [share + conv(hi) - conv(h), share + conv(lo) - conv(h)]
    assert out["converging_share"]["value"] == share
    assert out["converging_share"]["structural_range"] == pytest.approx(want)
    assert 0 < want[0] < share < want[1] < 1 and conv(h) > 0


def test_the_structural_subsample_runs_at_most_400_tilts():
    """With Monte Carlo runs of up to 1,000 tilts the structural subsample is 400 tilts long (drawn
    [seed, 8] as a 400-column array; a sequence whose entropy never reaches epsilon counts as 400):
    the random tilts' structural range recomputed on those sequences, the ball by bisection."""
    from kruskal_markov.convergence import monte_carlo_entropy_tilts
    from kruskal_markov.ensemble import random_sequences
    from kruskal_markov.entropy import entropy_trajectory

    m = _merging_model()
    seed, runs, eps, delta, sub, cap = 2, 20, 0.3, 1.0, 10, 400
    out = answer_intervals(m, seed=seed, count=100, length=12, epsilon=eps, runs=runs, max_steps=1000, draws=0,
                           structural_delta=delta, structural_sequences=sub)
    t = monte_carlo_entropy_tilts(m, eps, runs=runs, seed=[seed, 5], max_steps=1000)
    v = out["random_tilts"]["value"]
    assert t["censored"] == 0 and v == pytest.approx(t["mean"])
    firsts = []
    for s in random_sequences(2, sub, cap, seed=[seed, 8]):
        dist = entropy_trajectory(m, s, return_distributions=True).distributions
        hit = [None, None, None]                   # the entropy, the ball's smallest and largest
        for k, p in enumerate(dist):
            c = np.bincount(m.partition, weights=p, minlength=4)
            lo, hi = _range_by_bisection(c, delta * (1 - c.max() / c.sum()))
            e = -sum(x * np.log2(x) for x in c / c.sum() if x > 0)
            for j, x in enumerate((e, lo, hi)):
                if hit[j] is None and x <= eps:
                    hit[j] = k
            if None not in hit:
                break
        firsts.append([cap if x is None else x for x in hit])
    f = np.asarray(firsts, dtype=float)
    expect = [max(0.0, v + np.mean(f[:, 1] - f[:, 0])), v + np.mean(f[:, 2] - f[:, 0])]
    assert out["random_tilts"]["structural_range"] == pytest.approx(expect)
    assert expect[0] < v < expect[1]


def test_wilson_interval_by_its_definition():
    """Wilson's interval is the set of pi with n (p - pi)^2 <= z^2 pi (1 - pi): its ends solve that with
    equality (checked at each end, independently of the closed form), except where clipped to 0 or 1 at
    0 or n successes, where the other end is n / (n + z^2) or z^2 / (n + z^2); one trial is allowed."""
    from kruskal_markov.answers import wilson_interval

    z = 1.959963984540054
    for k, n in ((1, 1), (0, 1), (3, 7), (54, 60), (500, 1000), (1, 2000), (1999, 2000)):
        lo, hi = wilson_interval(k, n)
        p = k / n
        for end in (lo, hi):
            if 0 < end < 1:
                assert n * (p - end) ** 2 == pytest.approx(z * z * end * (1 - end), rel=1e-9), (k, n, end)
        assert lo <= p <= hi
        if k == n:
            assert (lo, hi) == pytest.approx((n / (n + z * z), 1.0))
        if k == 0:
            assert (lo, hi) == pytest.approx((0.0, z * z / (n + z * z)))
    assert wilson_interval(54, 60) == pytest.approx((0.7985, 0.9533), abs=1e-4)
    assert wilson_interval(3, 7, z=1.0) == pytest.approx(
        tuple((3 / 7 + 1 / 14 + s * np.sqrt(3 / 7 * 4 / 7 / 7 + 1 / 196)) / (1 + 1 / 7) for s in (-1, 1)))
    for k, n in ((0, 0), (-1, 3), (4, 3)):
        with pytest.raises(ValueError, match=f"^need 0 <= successes <= n and n >= 1, got {k} of {n}$"):
            wilson_interval(k, n)


def test_the_documented_defaults():
    """answer_intervals(model) with its defaults: 2,000 sequences of 50 tilts at 1e-3 bits, no runs, 20
    posterior draws on 200 sequences, 200 structural sequences; runs are censored at 1,000 tilts (a
    model that never reaches 1e-3 bits: every run counts 1,000)."""
    m = _counted_model()
    out = answer_intervals(m)
    assert out["settings"] == {"count": 2000, "length": 50, "epsilon": 1e-3, "runs": 0, "draws": 20,
                               "draw_count": 200, "structural_delta": 0.0, "structural_source": "none",
                               "structural_note": out["converging_share"]["note"], "structural_sequences": 200}
    assert set(out) == {"converging_share", "mean_entropy_10", "mean_entropy_20", "mean_entropy_50", "settings"}
    runs = answer_intervals(m, count=50, runs=5, draws=0)["random_tilts"]
    assert (runs["value"], runs["censored"], runs["mc_ci95"]) == (1000.0, 5, [None, None])

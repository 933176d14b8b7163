"""The builder's assembly (counts -> model) on hand-made explorations, judged by a dense recount.

No physics: the exploration state (representatives, their landings and fault codes, the start
poses and theirs) is written by hand, every landing an exact rotation of a representative, so the
state it lands in is known by construction. The judge counts the samples in plain Python loops,
row by row, and rebuilds what the model must hold: the matrices (counts over the non-faulted
samples; a start cell without samples takes the pooled first-tilt landings of the action; an
unexplored or all-faulted rest row stays put, or borrows the row of its nearest explored state),
the initial weights, the partition, the extras and the build statistics.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from transition_builder.builder.assembly import STATE_REST, STATE_START, STATE_UNEXPLORED, _aligned, _assemble
from transition_builder.builder.build_settings import BuildSettings
from transition_builder.builder.driver import _context
from transition_builder.builder.representatives import _with_rotations
from transition_builder.builder.state import NOT_DRAWN, _Exploration
from transition_builder.scene import scene_from_options
from transition_builder.status import ESCAPED, INVALID, OK, STATUS_NAMES, TIPPED, UNSETTLED

#: representatives (x, y, theta) of a 20 x 10 rectangle, clear of the walls and of each other's rotations
ORBITS = np.array([[60.0, 50.0, 0.3], [140.0, 70.0, 1.0], [100.0, 150.0, 2.0], [60.4, 50.0, 0.3],
                   [30.0, 110.0, 2.6]])
#: start poses (not a rotation-symmetric set, so some start cells have no sample for some actions)
STARTS = np.array([[50.0, 40.0, 0.1], [150.0, 45.0, 0.2], [70.0, 160.0, 1.7], [120.0, 120.0, 0.9],
                   [40.0, 90.0, 2.9], [95.0, 60.0, 1.2]])


def _landing(rng):
    """A landing: rotation ``r`` of representative ``t`` (by construction), or a fault code."""
    t, r = int(rng.integers(len(ORBITS))), int(rng.integers(4))
    return t, r


class _Case:
    """A hand-made exploration and the build context it is assembled in."""

    def __init__(self, settings, explored, seed, start_faults=(), rest_faults=(), not_drawn=(), more=0,
                 offset=(0.0, 0.0, 0.0)):
        self.scene = scene_from_options("rectangle:20x10")
        self.settings = settings
        self.c = _context(self.scene, settings, None, 1000, None, 60.0)
        sym, K, n_act = self.c.sym, self.c.K, self.c.n_act
        self.sym, self.K, self.n_act, self.G = sym, K, n_act, sym.order
        rng = np.random.default_rng(seed)
        ex = _Exploration(n_act, K)
        ex.add_orbits(ORBITS)
        ex.explored[:len(ORBITS)] = explored
        # rest landings: (orbit, action, sample) -> (target, rotation) or a status
        self.rest = {}
        for o in np.flatnonzero(explored):
            for b in range(n_act):
                for k in range(K):
                    t, r = _landing(rng)
                    ex.land[o, b, k] = sym.rotate_poses(ORBITS[t] + offset, r)[0]
                    ex.status[o, b, k] = OK
                    self.rest[o, b, k] = (t, r)
        for (o, b, k), code in rest_faults:
            ex.status[o, b, k] = code
            ex.land[o, b, k] = np.nan
            self.rest[o, b, k] = code
        for (o, b, k) in not_drawn:
            ex.status[o, b, k] = NOT_DRAWN
            ex.land[o, b, k] = np.nan
            self.rest[o, b, k] = NOT_DRAWN
        # samples beyond K of some explored rows (max_samples): one row per tilt
        src, land, status = [], [], []
        done = np.flatnonzero(explored)
        for i in range(more):
            o, b = int(done[i % len(done)]), int(rng.integers(n_act))
            t, r = _landing(rng)
            code = OK if i % 3 else UNSETTLED
            src.append((o, b, K + i))
            land.append(sym.rotate_poses(ORBITS[t] + offset, r)[0] if code == OK else [np.nan] * 3)
            status.append(code)
            self.rest[o, b, K + i] = (t, r) if code == OK else code
        if more:
            ex.more_src = np.array(src, dtype=np.int64)
            ex.more_land = np.array(land)
            ex.more_status = np.array(status, dtype=np.int8)
        # start landings under the action representatives
        n0 = len(STARTS)
        ex.start_poses = STARTS.copy()
        ex.start_land = np.full((len(self.c.reps), n0, 3), np.nan)
        ex.start_status = np.zeros((len(self.c.reps), n0), dtype=np.int8)
        self.start = {}
        for bi in range(len(self.c.reps)):
            for i in range(n0):
                t, r = _landing(rng)
                ex.start_land[bi, i] = sym.rotate_poses(ORBITS[t] + offset, r)[0]
                self.start[bi, i] = (t, r)
        for (bi, i), code in start_faults:
            ex.start_status[bi, i] = code
            ex.start_land[bi, i] = np.nan
            self.start[bi, i] = code
        self.ex = ex
        self.c.index.add(_with_rotations(sym, ex.orbit_poses))

    def assemble(self):
        return _assemble(self.scene, self.settings, self.sym, self.c.grid, self.c.index, self.ex, self.c.reps,
                         "KEY", {"run": 1})


def judge(case):
    """The model the assembly must build, recounted sample by sample."""
    sym, G, n_act, grid = case.sym, case.G, case.n_act, case.c.grid
    n_orb = len(ORBITS)
    rot_starts = [sym.rotate_poses(STARTS, j) for j in range(G)]
    cells = sorted({int(c) for j in range(G) for c in grid.voxel_index(rot_starts[j])})
    start_state = {(j, i): cells.index(int(grid.voxel_index(rot_starts[j][i:i + 1])[0]))
                   for j in range(G) for i in range(len(STARTS))}
    n_start = len(cells)
    n = n_start + n_orb * G

    def state(t, r):
        return n_start + t * G + r % G

    counts = np.zeros((n_act, n, n))
    samples = np.zeros((n_act, n), dtype=np.int64)
    faults = np.zeros((n_act, n), dtype=np.int64)
    kinds = np.zeros((n_act, len(STATUS_NAMES)), dtype=np.int64)

    def tally(a, src, outcome, j):
        if outcome == NOT_DRAWN:
            return
        samples[a, src] += 1
        if isinstance(outcome, tuple):
            counts[a, src, state(outcome[0], outcome[1] + j)] += 1
            kinds[a, OK] += 1
        else:
            faults[a, src] += 1
            kinds[a, outcome] += 1

    for (bi, i), outcome in case.start.items():
        for j in range(G):
            tally(sym.rotate_action(case.c.reps[bi], j), start_state[j, i], outcome, j)
    for (o, b, _k), outcome in case.rest.items():
        for j in range(G):
            tally(sym.rotate_action(b, j), state(o, j), outcome, j)
    explored = case.ex.explored[:n_orb]
    kind = np.full(n, STATE_UNEXPLORED)
    kind[:n_start] = STATE_START
    for o in np.flatnonzero(explored):
        kind[state(o, 0):state(o, 0) + G] = STATE_REST
    P, imputed, stay = _judge_rows(counts, n_start, case.borrow)
    initial = np.zeros(n)
    for (j, i), s in start_state.items():
        initial[s] += 1.0 / (G * len(STARTS))
    partition = np.concatenate([cells, grid.voxel_index(_with_rotations(sym, ORBITS))])
    return {"n_start": n_start, "n": n, "counts": counts, "P": P, "samples": samples, "faults": faults,
            "kinds": kinds, "kind": kind, "initial": initial, "partition": partition, "imputed": imputed,
            "stay": stay, "explored": int(explored.sum())}


def _judge_rows(counts, n_start, borrow):
    """The matrices from the counts, row by row: a row with samples is its normalised counts, a start
    row without any takes the action's pooled start landings (imputed), a rest row without any stays
    put unless it borrows; borrowed rows copy their lender's. Returns ``(P, imputed, stay)``."""
    n_act, n = counts.shape[:2]
    P = np.zeros_like(counts)
    imputed = stay = 0
    for a in range(n_act):
        pooled = counts[a, :n_start].sum(axis=0)
        for s in range(n):
            tot = counts[a, s].sum()
            if tot:
                P[a, s] = counts[a, s] / tot
            elif s < n_start:
                P[a, s] = pooled / pooled.sum()
                imputed += 1
            elif borrow.get(s) is None:
                P[a, s, s] = 1.0
                stay += 1
    for s, lender in borrow.items():
        P[:, s] = P[:, lender]
    return P, imputed, stay


def _check(case, model, stats, j):
    n, n_start, G, K = j["n"], j["n_start"], case.G, case.K
    assert model.n_states == n and model.actions == case.scene.actions
    np.testing.assert_allclose(model.initial, j["initial"], rtol=0, atol=1e-15)
    for a in range(case.n_act):
        np.testing.assert_allclose(model.matrices[a].toarray(), j["P"][a], rtol=0, atol=1e-15)
        # the counts of each stored entry (0 where the row was imputed, borrowed or stays put)
        m = model.matrices[a]
        rows = np.repeat(np.arange(n), np.diff(m.indptr))
        np.testing.assert_array_equal(model.extras[f"counts_{a}"], j["counts"][a][rows, m.indices])
        assert model.extras[f"counts_{a}"].dtype == np.int32
    np.testing.assert_array_equal(model.partition, j["partition"])
    assert model.n_cells == case.c.grid.n_voxels
    np.testing.assert_array_equal(model.extras["samples"], j["samples"])
    np.testing.assert_array_equal(model.extras["faults"], j["faults"])
    assert model.extras["samples"].dtype == np.int32 and model.extras["faults"].dtype == np.int32
    np.testing.assert_array_equal(model.extras["state_kind"], j["kind"])
    assert model.extras["state_kind"].dtype == np.int8
    poses = model.extras["state_poses"]
    assert np.all(np.isnan(poses[:n_start]))
    np.testing.assert_array_equal(poses[n_start:], _with_rotations(case.sym, ORBITS))
    total, n_faults = int(j["samples"].sum()), int(j["faults"].sum())
    scene, settings = case.scene, case.settings
    voxels = (math.ceil(200 / settings.tol_mm) ** 2 * math.ceil(math.pi / math.radians(settings.tol_deg)))
    want = {"states": n, "rest_states": j["explored"] * G, "start_states": n_start,
            "unexplored_states": (len(ORBITS) - j["explored"]) * G, "representatives": len(ORBITS),
            "voxels_total": voxels, "report_voxels": case.c.grid.n_voxels, "symmetry_order": G,
            "symmetry": case.sym.reason, "samples_per_row": K, "start_samples": len(STARTS),
            "fault_rate": n_faults / total, "faults": n_faults,
            "faults_per_action": {scene.actions[a]: {STATUS_NAMES[c]: int(j["kinds"][a, c])
                                                     for c in range(1, len(STATUS_NAMES))}
                                  for a in range(case.n_act)},
            "sampled_transitions": total, "tilts_saved_by_symmetry": total * (G - 1) // G,
            "start_rows_imputed": j["imputed"], "rows_without_samples": j["stay"],
            "rows_borrowed": len(case.borrow), "rows_borrowed_from_afar": case.afar,
            "noise": settings.noise, "run": 1}
    assert stats == want
    md = model.metadata
    assert md["build_key"] == "KEY" and md["kind"] == "kruskal.built_model"
    assert md["scene"] == scene.to_dict() and md["scene_hash"] == scene.content_hash()
    assert md["build_settings"] == settings.to_dict() and md["grid"] == case.c.grid.to_dict()
    assert md["noise"] == settings.noise and md["symmetry_order"] == G
    assert md["stats"] == {k: v for k, v in want.items() if k != "faults_per_action"}
    from transition_builder.builder.build_settings import BUILDER_VERSION
    assert md["builder_version"] == BUILDER_VERSION


def test_deterministic_build_with_faults_imputed_start_rows_and_unexplored_orbits():
    """One sample per row; every fault kind among the starts and the rest rows; one rest row whose
    every sample faulted (stays put); two unexplored orbits (stay put); start cells that only some
    rotations reach (imputed from the pooled first-tilt landings)."""
    start_faults = [((0, 0), TIPPED), ((0, 3), ESCAPED), ((1, 2), UNSETTLED), ((1, 5), INVALID)]
    rest_faults = [((0, 2, 0), TIPPED), ((1, 4, 0), ESCAPED), ((3, 0, 0), UNSETTLED), ((3, 6, 0), INVALID)]
    settings = BuildSettings(grid="2x2x2")
    case = _Case(settings, [True, True, False, True, False], 1, start_faults, rest_faults)
    case.borrow, case.afar = {}, 0
    j = judge(case)
    model, stats = case.assemble()
    assert j["imputed"] > 0 and j["stay"] > 0 and j["faults"].sum() == 4 * 4 + 4 * 4
    _check(case, model, stats, j)
    assert "borrowed_from" not in model.extras


def test_noisy_build_with_undrawn_and_extra_samples_and_borrowed_rows():
    """Two samples per row, some slots not drawn, samples beyond K in ``more_*``; unexplored orbits
    borrow the row of the nearest explored state: orbit 3 sits 0.4 mm from orbit 0 (within 8
    tolerance units, same cell), orbit 4 has nothing near and borrows from the nearest anywhere."""
    settings = BuildSettings(noise="pose:0.1,0.1", samples=2, grid="2x2x2", max_samples=4)
    assert settings.explore_weight > 0
    not_drawn = [(0, 1, 1), (1, 5, 1), (2, 7, 1)]
    rest_faults = [((0, 3, 0), TIPPED), ((2, 2, 1), ESCAPED)]
    case = _Case(settings, [True, True, True, False, False], 2, [((0, 1), TIPPED)], rest_faults, not_drawn, more=7)
    G, tol, tol_rad = case.G, settings.tol_mm, math.radians(settings.tol_deg)
    cells = {int(c) for jj in range(G) for c in case.c.grid.voxel_index(case.sym.rotate_poses(STARTS, jj))}
    n_start = len(cells)
    emb = _with_rotations(case.sym, ORBITS)

    def dist(p, q):          # tolerance units, theta modulo the rectangle's half turn
        dth = abs(p[2] - q[2]) % math.pi
        return math.hypot((p[0] - q[0]) / tol, (p[1] - q[1]) / tol, min(dth, math.pi - dth) / tol_rad)

    case.borrow = {}
    for r in range(G):
        # orbit 3's states lie 0.4 mm (0.53 units) from orbit 0's: the nearest, same cell
        assert dist(emb[3 * G + r], emb[0 * G + r]) < 1
        case.borrow[n_start + 3 * G + r] = n_start + 0 * G + r
        # orbit 4's have no explored state within 8 units: the nearest anywhere
        d = [dist(emb[4 * G + r], emb[s]) for s in range(3 * G)]
        assert min(d) > 8
        case.borrow[n_start + 4 * G + r] = n_start + int(np.argmin(d))
    case.afar = G
    j = judge(case)
    model, stats = case.assemble()
    _check(case, model, stats, j)
    want = np.full(j["n"], -1)
    for s, lender in case.borrow.items():
        want[s] = lender
    np.testing.assert_array_equal(model.extras["borrowed_from"], want)


def test_aligned_counts_at_the_stored_entries():
    """Counts of C at P's pattern, 0 where C has none; duplicates in C summed first."""
    import scipy.sparse as sp

    P = sp.csr_matrix(np.array([[0.5, 0.5, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]))
    C = sp.csr_matrix((np.array([1, 2, 3]), (np.array([0, 0, 1]), np.array([1, 1, 2]))), shape=(3, 3))
    out = _aligned(P, C)
    assert out.dtype == np.int32 and out.tolist() == [0, 3, 3, 0]
    assert _aligned(P, sp.csr_matrix((3, 3), dtype=np.int64)).tolist() == [0, 0, 0, 0]


@pytest.mark.parametrize("code", [TIPPED, ESCAPED, UNSETTLED, INVALID])
def test_every_fault_kind_is_counted_under_its_name(code):
    settings = BuildSettings(grid="2x2x2")
    case = _Case(settings, [True, False, False, False, False], 3, [], [((0, 2, 0), code)])
    case.borrow, case.afar = {}, 0
    _model, stats = case.assemble()
    per = stats["faults_per_action"]
    hit = {name: counts for name, counts in per.items() if any(counts.values())}
    # the fault of orbit 0 under action 2 appears once per rotation, under the rotated actions
    assert sum(counts[STATUS_NAMES[code]] for counts in hit.values()) == case.G
    assert all(set(counts) == set(STATUS_NAMES[1:]) for counts in per.values())


def test_noise_statistics_of_a_noisy_build():
    """Every landing 0.2 mm (x) and 0.3 degrees off its representative: the snapping spread is the
    root mean square per coordinate, (0.2 / sqrt 2 mm, 0.3 deg); the representatives' noise is the
    process noise, or with snap compensation sqrt(sigma^2 - spread^2) per coordinate. Zero noise: none."""
    from transition_builder.builder.assembly import _noise_stats
    from transition_builder.noise import NoiseSpec, parse_noise

    off = (0.2, 0.0, math.radians(0.3))
    for compensate in (False, True):
        settings = BuildSettings(noise="pose:0.5,1.0", samples=2, grid="2x2x2", snap_compensation=compensate)
        case = _Case(settings, [True, True, True, False, False], 4, offset=off)
        got = _noise_stats(settings, case.ex, case.c.index, case.sym)
        spread = (0.2 / math.sqrt(2), 0.3)
        assert got["snap_spread_mm"] == pytest.approx(spread[0], rel=1e-9)
        assert got["snap_spread_deg"] == pytest.approx(spread[1], rel=1e-9)
        compensated = NoiseSpec("pose", math.sqrt(0.25 - spread[0] ** 2), math.sqrt(1.0 - spread[1] ** 2))
        added = compensated if compensate else settings.noise_spec
        assert set(got) == {"snap_spread_mm", "snap_spread_deg", "representative_noise"}
        noise = parse_noise(got["representative_noise"])
        assert (noise.sigma_mm, noise.sigma_deg) == (pytest.approx(added.sigma_mm, rel=1e-9),
                                                     pytest.approx(added.sigma_deg, rel=1e-9))
    quiet = BuildSettings(grid="2x2x2")
    case = _Case(quiet, [True, False, False, False, False], 4)
    assert _noise_stats(quiet, case.ex, case.c.index, case.sym) == {}


def test_weighted_build_with_nothing_explored_keeps_every_rest_row_in_place():
    """No explored state to borrow from: every rest row stays put, none borrows (not a start row)."""
    settings = BuildSettings(noise="pose:0.1,0.1", samples=2, grid="2x2x2")
    case = _Case(settings, [False] * 5, 5)
    case.borrow, case.afar = {}, 0
    model, stats = case.assemble()
    _check(case, model, stats, judge(case))
    assert stats["rows_borrowed"] == 0 and "borrowed_from" not in model.extras


def test_unused_voxels_still_count_as_cells():
    """A 4 x 4 x 4 grid whose last voxels hold no state: the model has every report cell."""
    settings = BuildSettings(grid="4x4x4")
    case = _Case(settings, [True, True, False, True, False], 6)
    case.borrow, case.afar = {}, 0
    model, stats = case.assemble()
    assert model.partition.max() < case.c.grid.n_voxels - 1
    assert model.n_cells == 64
    _check(case, model, stats, judge(case))


def test_an_action_that_never_landed_cannot_be_assembled():
    """Every sample of action 2 (and so of its rotations) faulted: its start rows have nothing to
    impute from, and the model refuses the empty rows (ModelError, one line)."""
    from kruskal_markov.model import ModelError

    settings = BuildSettings(grid="2x2x2")
    case = _Case(settings, [True, False, False, False, False], 7)
    for bi in range(len(case.c.reps)):
        for i in range(len(STARTS)):
            case.ex.start_status[bi, i] = TIPPED
    case.ex.status[0] = TIPPED
    with pytest.raises(ModelError, match="sums to 0"):
        case.assemble()


def test_a_landing_without_representative_is_an_internal_error():
    settings = BuildSettings(grid="2x2x2")
    case = _Case(settings, [True, False, False, False, False], 8)
    case.ex.land[0, 1, 0] = [150.0, 150.0, 0.7]           # far from every representative
    with pytest.raises(RuntimeError, match="^a landing has no representative within tolerance after exploration$"):
        case.assemble()


def test_aligned_counts_with_one_stored_count():
    import scipy.sparse as sp

    P = sp.csr_matrix(np.array([[0.5, 0.5], [0.0, 1.0]]))
    C = sp.csr_matrix(np.array([[2, 0], [0, 0]]))
    assert _aligned(P, C).tolist() == [2, 0, 0]

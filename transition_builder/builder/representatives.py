"""Representatives: landings offered to the snapping index, members, recentring and refinement.

A landing joins the nearest representative within tolerance or founds a new orbit (:func:`_offer`);
the members of a representative are the landings snapped to it, rotated back into its frame
(:func:`_members`), from which recentring moves it (:func:`_recenter`) and refinement picks the
farthest (:func:`_refinement_candidates`).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from transition_builder._density import neighbour_counts
from transition_builder.builder.state import NOT_DRAWN, _Exploration
from transition_builder.noise import NoiseSpec
from transition_builder.snapping import PoseIndex
from transition_builder.symmetry import TraySymmetry

_PARALLEL_QUERY = 100_000   # landings from which a k-d tree query runs on every core (_query_workers)


_RECENTER_RADIUS = 0.05     # tolerance units: members this close count as one resting point


def _offer(index: PoseIndex, ex: _Exploration, sym: TraySymmetry, landings: np.ndarray,
           embedded: np.ndarray | None = None) -> int:
    """Offer landings (in order, already rotated as needed) to the index; found new orbits.

    A landing with no representative within tolerance (same cell and contacts) founds an orbit:
    its ``G`` rotations join the index. Returns the number of orbits founded. Offering the
    landings of many orbits in one call founds exactly what offering them orbit by orbit would:
    a landing is checked against every representative there was before the call (one vectorised
    query) and against the rotations of every landing that founded an orbit before it in this
    call (neighbour lists among the call's misses, then one pass in order). The builder offers a
    whole batch at once. ``embedded``: ``index.embed(landings)[0]`` when the caller has it already.
    """
    ok = np.all(np.isfinite(landings), axis=1)
    cand = landings[ok]
    if len(cand) == 0:
        return 0
    q = index.embed(cand)[0] if embedded is None else embedded[ok]
    if len(q) > 64:
        index.compact()                                  # many queries: all through the tree
    hit, _ = index.nearest_embedded(q, _query_workers(len(q)))
    miss = np.flatnonzero(hit < 0)
    if len(miss) == 0:
        return 0
    G = sym.order
    rot = _with_rotations(sym, cand[miss]).reshape(-1, G, 3)
    rq, _ = index.embed(rot.reshape(-1, 3))
    # every (rotation, miss) pair within tolerance, grouped by miss (the pairs of
    # ``query_ball_point(q[miss], r)``, without a Python list per miss)
    pairs = cKDTree(rq, boxsize=index.box).sparse_distance_matrix(
        cKDTree(q[miss], boxsize=index.box), 1.0 + 1e-12, output_type="ndarray")
    by_miss = np.argsort(pairs["j"], kind="stable")
    indptr = np.concatenate(([0], np.cumsum(np.bincount(pairs["j"], minlength=len(miss)))))
    founds = np.zeros(len(miss), dtype=bool)
    _found_in_order(indptr, pairs["i"][by_miss].astype(np.int64), G, founds)
    if founds.any():
        index.add(rot[founds].reshape(-1, 3))
        ex.add_orbits(cand[miss[founds]])
    return int(founds.sum())


@njit(cache=True)
def _found_in_order(indptr, neighbours, G, founds):
    """Miss ``t`` founds an orbit unless a rotation of an earlier miss that founded one lies within
    tolerance (``neighbours[indptr[t]:indptr[t + 1]]``, rotation indices; rotation ``r`` belongs to
    miss ``r // G``): the one pass in order of :func:`_offer`, compiled."""
    for t in range(founds.shape[0]):
        hit = False
        for e in range(indptr[t], indptr[t + 1]):
            owner = neighbours[e] // G
            if owner < t and founds[owner]:
                hit = True
                break
        founds[t] = not hit


def _query_workers(n: int) -> int:
    """Threads for a k-d tree query of ``n`` landings: every core for the large ones (all landings
    at once, between phases, while the simulation workers wait), one otherwise (the offers made
    while the workers run, which would take cores from them)."""
    return -1 if n >= _PARALLEL_QUERY else 1


def _with_rotations(sym: TraySymmetry, poses: np.ndarray) -> np.ndarray:
    """Every pose of ``poses`` (any leading shape, last axis x, y, theta; taken in C order) followed
    by its ``G`` rotations: ``(n * G, 3)``, pose-major. The order in which landings are offered
    and in which an orbit's states are numbered."""
    flat = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    rot = np.stack([sym.rotate_poses(flat, j) for j in range(sym.order)], axis=1)   # (n, G, 3)
    return rot.reshape(-1, 3)


def _members(ex: _Exploration, index: PoseIndex, sym: TraySymmetry):
    """Every landing so far (start and explored, every rotation) that lies within tolerance of a
    representative: ``(landing, orbit, member, distance, embedded)``, where ``member`` is the
    landing turned back into its orbit's frame, ``distance`` its distance to the state in tolerance
    units and ``embedded`` the landing's query coordinates (:meth:`PoseIndex.embed`)."""
    G = sym.order
    pools = [sym.rotate_poses(ex.start_land[b], j) for b in range(len(ex.start_land)) for j in range(G)]
    done = np.flatnonzero(ex.explored[:ex.n_orbits])
    flat = ex.land[done].reshape(-1, 3)
    pools += [sym.rotate_poses(flat, j) for j in range(G)]
    land = np.concatenate(pools)
    land = land[np.all(np.isfinite(land), axis=1)]
    q, _ = index.embed(land)
    index.compact()                                      # many queries: all through the tree
    tgt, dist = index.nearest_embedded(q, _query_workers(len(q)))
    keep = tgt >= 0
    land, tgt, dist, q = land[keep], tgt[keep], dist[keep], q[keep]
    orbit, rot = tgt // G, tgt % G
    members = np.empty_like(land)
    for j in range(G):
        sel = rot == j
        members[sel] = sym.rotate_poses(land[sel], -j)
    return land, orbit, members, dist, q


def _snap_spread(ex: _Exploration, index: PoseIndex, sym: TraySymmetry) -> tuple[float, float]:
    """Root-mean-square offset of the snapped landings from their representatives, per coordinate:
    ``(mm in x and y, degrees in theta)`` (theta modulo the shape's symmetry)."""
    _, orbit, members, _, _ = _members(ex, index, sym)
    if len(orbit) == 0:
        return 0.0, 0.0
    d = members - ex.orbit_poses[orbit]
    period = index.period
    dth = np.mod(d[:, 2] + 0.5 * period, period) - 0.5 * period
    return (float(np.sqrt(np.mean(0.5 * (d[:, 0] ** 2 + d[:, 1] ** 2)))),
            float(np.degrees(np.sqrt(np.mean(dth ** 2)))))


def compensated_noise(noise: NoiseSpec, spread_mm: float, spread_deg: float) -> NoiseSpec:
    """The noise to add to a representative so that, with the snapping offset it stands for, the
    total perturbation has the variance of ``noise``: ``sigma' = sqrt(max(0, sigma^2 - spread^2))``
    per coordinate (variances of independent offsets add; ``BuildSettings.snap_compensation``).

    Parameters
    ----------
    noise : NoiseSpec
        The process noise.
    spread_mm, spread_deg : float
        Root mean square snapping offset (mm in x and y, degrees in theta).

    Returns
    -------
    NoiseSpec
        The reduced noise (``noise`` itself when it is zero).

    Examples
    --------
    >>> from transition_builder.noise import parse_noise
    >>> str(compensated_noise(parse_noise("pose:0.5,1"), 0.3, 0.0))
    'pose:0.4,1'
    """
    if noise.is_zero:
        return noise
    return NoiseSpec("pose", math.sqrt(max(0.0, noise.sigma_mm ** 2 - spread_mm ** 2)),
                     math.sqrt(max(0.0, noise.sigma_deg ** 2 - spread_deg ** 2)))


def _recenter(ex: _Exploration, index: PoseIndex, sym: TraySymmetry) -> int:
    """Move every representative to the densest point of its members; returns how many moved.

    Members are all landings (start and explored, every rotation) snapped to one of the orbit's
    states, rotated back to the orbit's frame. The density of a member is the number of members
    within ``_RECENTER_RADIUS`` (tolerance units); a representative moves to its densest member
    if that member is shared by at least two landings and lies farther than the radius. Moved
    orbits lose their landings and are explored again; landings that no longer have a
    representative within tolerance found new orbits (so every landing stays covered).
    """
    G = sym.order
    land, orbit, members, _, land_q = _members(ex, index, sym)
    mq, _ = index.embed(members)
    density = neighbour_counts(mq[:, :3], orbit, _RECENTER_RADIUS, index.box[2])   # within one orbit
    order = np.lexsort((np.arange(len(orbit)), -density, orbit))
    first = order[np.r_[True, orbit[order][1:] != orbit[order][:-1]]] if len(order) else order
    first = first[(density[first] >= 2) & ex.explored[orbit[first]]]
    rq, _ = index.embed(ex.orbit_poses[orbit[first]])
    first = first[index.wrapped_norm(mq[first, :3] - rq[:, :3]) > _RECENTER_RADIUS]
    if len(first) == 0:
        return 0
    o = orbit[first]                                    # distinct orbits
    p = members[first]
    ex.orbit_poses[o] = p
    ex.explored[o] = False
    ex.land[o] = np.nan
    ex.status[o] = NOT_DRAWN
    index.move((o[:, None] * G + np.arange(G)).reshape(-1), _with_rotations(sym, p))
    _offer(index, ex, sym, land, land_q)                # landings left uncovered found new orbits
    return len(first)


def _refinement_candidates(ex: _Exploration, index: PoseIndex, sym: TraySymmetry, min_dist: float) -> np.ndarray:
    """For every explored orbit, its farthest member (a landing snapped to one of its states, rotated
    back to the orbit's frame) if farther than ``min_dist`` (normalised units); rows (orbit, x, y, theta)."""
    _, orbit, members, dist, _ = _members(ex, index, sym)
    keep = dist > min_dist
    orbit, members, dist = orbit[keep], members[keep], dist[keep]
    # farthest member per orbit (ties: first in offering order)
    order = np.lexsort((np.arange(len(orbit)), -dist, orbit))
    first = order[np.r_[True, orbit[order][1:] != orbit[order][:-1]]] if len(order) else order
    first = first[ex.explored[orbit[first]]]
    return np.column_stack([orbit[first].astype(np.float64), members[first]])

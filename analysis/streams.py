"""Every random stream of :mod:`analysis` in one table.

A result is reproducible from ``--seed`` alone because each use of randomness draws from its own
stream of that seed, never from the bare seed shared with another use. Two kinds:

- **Salted streams** (:data:`SALTS`): ``numpy.random.default_rng([seed, salt, *index])``
  (:func:`salted`, :func:`salted_rng`). The integers are part of every output drawn from them
  (``--sequence random:N`` is the same N actions in every command because they all use the salt
  ``sequences``); changing one changes published figures, so they are fixed here and nowhere else.
- **Named streams of the report** (:data:`REPORT_STREAMS`): :func:`stream_seed` of the run's seed
  and a name, e.g. ``"A"`` or ``"B:triangle:3"`` (the part after ``:`` indexes the stream's family).
  A name is hashed, so a new section's stream needs no number and cannot collide with another's.

Not here: the builder's keyed streams (``transition_builder``: start poses, noise, refinement) stay
numeric in their modules because they are part of a cached model's identity (its build key), and the
mathematics package's streams (``kruskal_markov.answers``) are its own. Start poses of direct
simulation use the bare seed (``kruskal simulate --seed S``), and ``check_plan_between`` in
:mod:`analysis.friction_range` gives coefficient ``i`` the seed ``seed + i`` (:func:`offset_seed`):
a paired comparison, echoed in its JSON.
"""
from __future__ import annotations

import hashlib

import numpy as np

__all__ = ["SALTS", "REPORT_STREAMS", "salted", "salted_rng", "stream_seed", "offset_seed"]

#: name -> integer salt of ``default_rng([seed, salt, *index])``; who draws from it.
SALTS: dict[str, int] = {
    "sequences": 1,                       # analysis.sequences: ``--sequence random:N``, validate's sequences
    "validate.reference": 2,              # analysis.validate.reference_seed: [seed, 2, i], sequence i's trials
    "validate.bootstrap": 3,              # analysis.validate: the reference's bootstrap and plug-in draws
    "validate.posterior": 4,              # analysis.validate: posterior draws of the model's band, [seed, 4, r]
    "orientability.entropy_tilts": 5,     # analysis.orientability: Monte Carlo random tilts to entropy <= eps
    "orientability.sync_length": 6,       # analysis.orientability: Monte Carlo random synchronizing length
    # analysis.fit: bootstraps [seed, fit]; entropy band [seed, fit, 1]; goodness of fit [seed, fit, 2];
    # fit --design, candidate i's simulated trials [seed, fit, 3, i]; fit --calibrate, calibration
    # log k's start poses and process noise [seed, fit, 4, k] and its camera noise [seed, fit, 5, k]
    "fit": 0x464954,
    # analysis.fit.study: hidden coefficient [seed, s]; sequence [seed, s, 1]; analysis.fit.study_pair: the
    # pair's hidden mu_k and gap [seed, s, 2], its sequence [seed, s, 3], its start poses' seed [seed, s, 4]
    "tray_log": 0x7E41,
    # analysis.fit.study.add_camera_noise: the first log's [seed, s], the pair's log's [seed, s, 1]
    "tray_log.camera": 0xCA,
    "kit.compartment": 0x6B6974,          # analysis.kit_replay.compartment_seed: [seed, i, salt], compartment i > 0
}

#: the report's named streams (``ctx.seed(name)``): family -> what draws from it. ``family:x`` is
#: one stream per ``x`` (a part, a map, a target, a sequence index).
REPORT_STREAMS: dict[str, str] = {
    "A": "experiment A's random sequences (also the contact and sensitivity comparisons: common numbers)",
    "A.check": "the direct simulation of A's best sequence",
    "answers": "the ensemble and intervals of every model's paper-level answers",
    "ensemble": "A at scale: the million random sequences",
    "metrics": "the orientability metrics of each model",
    "validation": "the key's model against direct simulation",
    "sync.replay": "the shortest plan replayed in direct simulation",
    "plans.words": "random words of each plan target (plans.words:TARGET)",
    "plans.replay": "each target's plan replayed (plans.replay:TARGET)",
    "plans.interval": "the interval of a plan's success probability",
    "sensitivity.check": "direct checks of the sensitivity models (sensitivity.check:I)",
    "B": "experiment B's direct simulation of each part (B:SHAPE)",
    "C": "experiment C's direct simulation on each friction map (C:MAP)",
    "friction_study": "the friction study's seed",
    "tray_log": "the tray-log study's seed (its hidden coefficient, log and fit; the pair's log and fit; the design)",
    "kits": "the kits section's random sequences (the kit's ensemble and convergence)",
    "kits.design": "the key's tray design sweep",
    "kits.replay": "the kit's common plan replayed in direct simulation",
}


def salted(seed, name: str, *index: int) -> list[int]:
    """The entropy ``[seed, SALTS[name], *index]`` of a salted stream (what ``seed=`` takes).

    Parameters
    ----------
    seed : int
        The command's ``--seed``.
    name : str
        A key of :data:`SALTS` (KeyError for another).
    *index : int
        Further words: one stream per sequence, draw, ...

    Returns
    -------
    list of int

    Examples
    --------
    >>> salted(7, "validate.posterior", 2)
    [7, 4, 2]
    """
    return [int(seed), SALTS[name], *(int(i) for i in index)]


def salted_rng(seed, name: str, *index: int) -> np.random.Generator:
    """``numpy.random.default_rng(salted(seed, name, *index))``.

    Parameters
    ----------
    seed, name, *index
        As :func:`salted`.

    Returns
    -------
    numpy.random.Generator

    Examples
    --------
    >>> int(salted_rng(0, "sequences").integers(8)) == int(np.random.default_rng([0, 1]).integers(8))
    True
    """
    return np.random.default_rng(salted(seed, name, *index))


def offset_seed(seed: int, i: int) -> int:
    """``seed + i``: the seed of member ``i`` of a paired comparison (the same starts for the same ``i``).

    Parameters
    ----------
    seed, i : int

    Returns
    -------
    int
    """
    return int(seed) + int(i)


def stream_seed(seed: int, name: str) -> int:
    """The seed of the named stream ``name`` under the run's ``seed``: a
    :class:`numpy.random.SeedSequence` of ``(seed, sha256(name))``, reduced to 31 bits.

    Two names, or two run seeds, give unrelated streams (``seed + k`` would not: seed 1's first
    stream would be seed 0's second). The name's hash is stable across runs and machines.

    Parameters
    ----------
    seed : int
        The run's seed.
    name : str
        The stream's name (its family in :data:`REPORT_STREAMS`, e.g. ``"B:triangle:3"``).

    Returns
    -------
    int
        A seed in ``[0, 2**31)``.

    Examples
    --------
    >>> stream_seed(0, "A") == stream_seed(0, "A") != stream_seed(1, "A")
    True
    >>> stream_seed(0, "A") != stream_seed(0, "ensemble")
    True
    """
    h = int.from_bytes(hashlib.sha256(name.encode()).digest()[:8], "little")
    state = np.random.SeedSequence([int(seed), h]).generate_state(1, np.uint32)[0]
    return int(state >> 1)

"""Synchronizing words: support automata, synchronizability, shortest and greedy reset words,
and epsilon-synchronizing words of stochastic models.

A *synchronizing* (reset) word ``w`` drives a start set ``S`` of states to a single state:
``|S . w| = 1``. For a deterministic automaton ``S`` is the whole state set (a reset word); for a
tray model it is the support of the initial distribution. For a stochastic model we work on its
*support automaton* (entries ``>= threshold``), where the image of a set is the union of the
supports of its states: a word that synchronizes the support automaton orients the part with
certainty (up to the dropped probability mass).

Algorithms
----------
* Synchronizability: the pair graph (Cerny 1964; Eppstein 1990): a deterministic automaton is
  synchronizing iff every pair of states can be merged, decided in ``O(k n^2)``.
* Exact shortest word: bidirectional breadth-first search over subsets stored as bitsets --
  images of the start set forward, preimages of singletons backward, meeting when a forward set is
  contained in a backward set -- as in Kisielewicz, Kowalski and Szykula, "Computing the shortest
  reset words of synchronizing automata", J. Comb. Optim. 29 (2015), and Kisielewicz and Szykula,
  "Experiments with synchronizing automata", CIAA 2016. ``exact`` is True only when the search
  proved optimality.
* Greedy: Eppstein, "Reset sequences for monotonic automata", SIAM J. Comput. 19 (1990):
  repeatedly merge the pair with the shortest merging word.
* Plans (:mod:`kruskal_markov.sync.plan`): the targets ``state``, ``cell`` and ``probability:E``
  (:mod:`kruskal_markov.sync.targets`), searched exactly by iterative-deepening depth-first search
  with admissible bounds, a transposition table and a beam search for a first upper bound.

The family is one subpackage, one module per method (networkx's ``shortest_paths`` is the pattern):
``automaton`` (support automata), ``pairs`` (the pair test), ``exact`` (shortest reset words; its
design switches in ``options``), ``greedy``, ``epsilon``, ``targets`` and ``plan``. Every public name
is importable from here.
"""
from __future__ import annotations

# re-exports: every public name the former module sync.py defined stays importable from here (its
# private helpers are not re-exported: tests and callers use the public functions, or the
# module that defines a helper)
# ruff: noqa: F401
from kruskal_markov._subsets import SubsetStore, as_start, pair_index
from kruskal_markov.sync.automaton import (
    SyncAutomaton,
    as_automaton,
    is_synchronizing_word,
    start_set,
    support_automaton,
)
from kruskal_markov.sync.epsilon import epsilon_synchronizing_word
from kruskal_markov.sync.exact import shortest_synchronizing_word
from kruskal_markov.sync.greedy import greedy_synchronizing_word
from kruskal_markov.sync.options import ExactSearchOptions
from kruskal_markov.sync.pairs import (
    PAIR_CHECK_BYTES,
    eppstein_memory_mb,
    pair_check_memory_mb,
    synchronizability,
)
from kruskal_markov.sync.plan import PlanResult, random_word_success, shortest_plan, state_plan
from kruskal_markov.sync.result import SyncResult
from kruskal_markov.sync.shortest import choose_method, shortest_word
from kruskal_markov.sync.targets import Target, parse_target

__all__ = [
    "ExactSearchOptions",
    "PlanResult",
    "SyncAutomaton",
    "SyncResult",
    "Target",
    "as_automaton",
    "choose_method",
    "epsilon_synchronizing_word",
    "greedy_synchronizing_word",
    "is_synchronizing_word",
    "pair_check_memory_mb",
    "parse_target",
    "random_word_success",
    "shortest_plan",
    "shortest_synchronizing_word",
    "shortest_word",
    "start_set",
    "state_plan",
    "support_automaton",
    "synchronizability",
]

"""One entry point for "the shortest word that orients the part": :func:`shortest_word`.

Like networkx's ``shortest_path(G, ..., method=)``: one function, a ``method`` chosen by
:func:`choose_method` (the one place the rule lives) unless named, and one result type,
:class:`~kruskal_markov.sync.plan.PlanResult` (action names, ``to_dict``). The method-specific
searches stay available: :func:`~kruskal_markov.sync.exact.shortest_synchronizing_word` (the
bidirectional subset search, returning the letter-index
:class:`~kruskal_markov.sync.result.SyncResult`) and :func:`~kruskal_markov.sync.plan.shortest_plan`.

Budgets have one vocabulary across the family: ``time_budget`` (seconds, None: no limit),
``node_budget`` (subsets or images generated; the same budget gives the same answer on any
machine), ``memory_budget_mb`` and ``max_length``.

See Also
--------
kruskal_markov.sync.plan.shortest_plan : every target, robust plans over several models.
kruskal_markov.sync.exact.shortest_synchronizing_word : the subset search on an automaton.
kruskal_markov.sync.epsilon.epsilon_synchronizing_word : entropy targets on distributions.
"""
from __future__ import annotations

from kruskal_markov.model import TransitionModel

__all__ = ["METHODS", "choose_method", "shortest_word"]

#: the searches :func:`shortest_word` can run: ``subsets`` (bidirectional subset search,
#: Kisielewicz, Kowalski and Szykula 2015, greedy fallback at the budget) and ``plan`` (IDA* with
#: cell-reachability bounds, :func:`~kruskal_markov.sync.plan.shortest_plan`).
METHODS = ("auto", "subsets", "plan")


def choose_method(source, target: str = "state", start: str = "auto", threshold: float = 0.0) -> str:
    """The search :func:`shortest_word` runs with ``method="auto"``.

    A built tray model (a report partition, a non-deterministic support automaton) synchronized
    from its initial support goes to the plan search, which proves what the subset search cannot
    hold in memory (70,776 states: 11 tilts in about a minute); cell and probability targets need
    it too. An automaton, a deterministic model, or the whole state set (``start="all"``) go to
    the subset search.

    Parameters
    ----------
    source : TransitionModel or SyncAutomaton
    target : str
        ``state``, ``cell`` or ``probability:E``.
    start : {"auto", "all", "initial"}
        The start set (``auto``: all states of a deterministic model, else the initial support).
    threshold : float
        Support automaton threshold (a model whose support automaton is deterministic at it goes
        to the subset search).

    Returns
    -------
    str
        ``"plan"`` or ``"subsets"``.

    Examples
    --------
    >>> from kruskal_markov.automaton_json import model_from_automaton
    >>> cerny4 = model_from_automaton({"states": 4, "actions": {"a": [1, 2, 3, 0], "b": [0, 1, 2, 0]}})
    >>> choose_method(cerny4), choose_method(cerny4, "cell")
    ('subsets', 'plan')
    """
    if str(target) != "state":
        return "plan"
    if not isinstance(source, TransitionModel) or start == "all" or source.partition is None:
        return "subsets"
    from kruskal_markov.sync.automaton import support_automaton

    return "subsets" if support_automaton(source, threshold).deterministic else "plan"


def _start(model, start: str):
    from kruskal_markov.sync.automaton import start_set

    whole = {"auto": None, "all": True, "initial": False}[start]
    if whole is None:
        whole = model.is_deterministic()
    return start_set(model, whole)


def shortest_word(source, target: str = "state", *, method: str = "auto", start: str = "auto",
                  threshold: float = 0.0, time_budget: float | None = 60.0, node_budget: int | None = None,
                  memory_budget_mb: float | None = None):
    """The shortest word that meets ``target`` from the start set of ``source``.

    Parameters
    ----------
    source : TransitionModel or SyncAutomaton
        A model (its support automaton at ``threshold``) or an automaton (target ``state`` only).
    target : str
        ``state`` (one model state), ``cell`` (one report cell) or ``probability:E``
        (:func:`~kruskal_markov.sync.targets.parse_target`).
    method : {"auto", "subsets", "plan"}
        The search (:data:`METHODS`); ``auto`` is :func:`choose_method`.
    start : {"auto", "all", "initial"}
        The start set of a model for the subset search (``auto``: all states of a deterministic
        model, else the initial support; the plan search starts from the initial support).
    threshold : float
        Support automaton threshold.
    time_budget : float or None
        Seconds (None: no limit).
    node_budget : int or None
        Subsets (``subsets``) or images (``plan``) generated (None: each search's default).
    memory_budget_mb : float or None
        Memory of the search's tables (None: each search's default, 2048 MB for ``subsets``,
        1024 MB for ``plan``).

    Returns
    -------
    PlanResult
        Action names; ``method`` says which search answered (``plan-`` before the plan search's own
        name for target ``state``, as ``kruskal sync`` reports it); ``nodes`` the subsets or images
        generated; ``upper_bound`` the greedy word's length when the subset search found one.

    See Also
    --------
    choose_method, kruskal_markov.sync.plan.shortest_plan,
    kruskal_markov.sync.exact.shortest_synchronizing_word

    Examples
    --------
    >>> from kruskal_markov.automaton_json import model_from_automaton
    >>> cerny4 = model_from_automaton({"states": 4, "actions": {"a": [1, 2, 3, 0], "b": [0, 1, 2, 0]}})
    >>> r = shortest_word(cerny4)
    >>> r.length, r.exact, "".join(r.word), r.method
    (9, True, 'baaabaaab', 'bidirectional-bfs')
    >>> shortest_word(cerny4, method="plan").length
    9
    """
    from kruskal_markov.sync.plan import DEFAULT_NODE_BUDGET, PlanResult, shortest_plan

    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    chosen = choose_method(source, target, start, threshold) if method == "auto" else method
    if chosen == "plan":
        if not isinstance(source, TransitionModel):
            raise ValueError("the plan search needs a TransitionModel (an automaton has no cells)")
        r = shortest_plan(source, target, node_budget=DEFAULT_NODE_BUDGET if node_budget is None else node_budget,
                          time_budget=time_budget, threshold=threshold,
                          **({} if memory_budget_mb is None else {"memory_budget_mb": memory_budget_mb}))
        if str(target) == "state":
            import dataclasses

            r = dataclasses.replace(r, method="plan-" + r.method)
        return r
    if str(target) != "state":
        raise ValueError(f"the subset search answers target 'state' only, not {target!r}")
    from kruskal_markov.sync.automaton import support_automaton
    from kruskal_markov.sync.exact import shortest_synchronizing_word

    if isinstance(source, TransitionModel):
        aut, starts, actions = support_automaton(source, threshold), _start(source, start), source.actions
    else:
        aut, starts, actions = source, None, getattr(source, "actions", None)
    res = shortest_synchronizing_word(aut, starts, time_budget=time_budget, node_budget=node_budget,
                                      **({} if memory_budget_mb is None else {"memory_budget_mb": memory_budget_mb}))
    return PlanResult.from_sync(res, actions)

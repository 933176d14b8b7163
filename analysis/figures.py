"""Figures shared by the report and the benchmarks (matplotlib, written to files; nothing shown)."""
from __future__ import annotations

__all__ = ["random_word_success_figure"]


def random_word_success_figure(curves: dict, path, optimum: dict | None = None, title: str | None = None):
    """How rare are good plans: the probability that a random word of length L orients the part.

    Parameters
    ----------
    curves : dict
        Target name -> the dict of :func:`kruskal_markov.sync.plan.random_word_success`
        (``lengths``, ``probability``, ``ci95``).
    path : str or path-like
        Where the PNG goes.
    optimum : dict, optional
        Target name -> the shortest plan's length (a marker on the curve's axis).
    title : str, optional

    Returns
    -------
    str
        The path written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, ax = plt.subplots(figsize=(6.5, 4))
    colors = ["tab:blue", "tab:red", "tab:green", "tab:purple"]
    for (name, c), color in zip(curves.items(), colors):
        x = np.asarray(c["lengths"])
        p = np.asarray(c["probability"])
        ci = np.asarray(c["ci95"])
        ax.plot(x, p, "-", color=color, label=f"{name} ({c['words']:,} random words)")
        ax.fill_between(x, ci[:, 0], ci[:, 1], color=color, alpha=0.2, lw=0)
        if optimum and optimum.get(name) is not None:
            ax.axvline(optimum[name], color=color, ls=":", lw=1)
            ax.annotate(f"shortest plan: {optimum[name]}", (optimum[name], 0.02), color=color, fontsize=7,
                        rotation=90, va="bottom", ha="right")
    ax.set_xlabel("word length L (tilts)")
    ax.set_ylabel("P(random word of length L orients the part)")
    ax.set_ylim(-0.02, 1.02)
    ax.legend(fontsize=8)
    ax.set_title(title or "how rare are good plans (from the model)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return str(path)

"""The fit's figure: the criterion over the range (a heat map over the static/kinetic pair's
triangle), and the log's entropy beside the fitted model's."""
from __future__ import annotations

__all__ = ["fit_figure"]


def fit_figure(result: dict, path, truth=None) -> str:
    """Write the two-panel figure of a ``kruskal fit`` result (its ``to_dict``) to ``path`` (PNG).

    Left: the criterion at every grid point (log-likelihood, or minus the histogram distance),
    the estimate and its 90% interval (and ``truth`` when known); for the pair ``mu_s, mu_k`` the
    criterion below its best as a heat map over (``mu_k``, ``mu_s``), with the estimate and the
    rectangle of the two 90% intervals (``truth`` is then a (``mu_s``, ``mu_k``) pair). Right: the
    log's entropy curve against the fitted model's prediction with its 90% band for a log of this
    size.

    Returns
    -------
    str
        ``path``.
    """
    import os
    import tempfile

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    if set(result["estimate"]) == {"mu_s", "mu_k"}:
        _pair_panel(a1, result, truth)
    else:
        _line_panel(a1, result, truth)
    ent = result["goodness_of_fit"]["entropy"]
    k = np.arange(len(ent["model"]))
    a2.plot(k, ent["log"], ".-", color="k", label="log")
    a2.plot(k, ent["model"], "-", color="tab:blue", label="fitted model")
    a2.fill_between(k, ent["band_lo"], ent["band_hi"], color="tab:blue", alpha=0.2, label="90% band (log size)")
    a2.set_xlabel("tilt")
    a2.set_ylabel("entropy (bits)")
    a2.set_title("goodness of fit")
    a2.legend(fontsize=8)
    fig.tight_layout()
    path = os.fspath(path)
    d = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".fit-", suffix=".png", dir=d)
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=110)
        os.replace(tmp, path)
    finally:
        plt.close(fig)
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


def _criterion(result):
    import numpy as np

    use_ll = result.get("criterion_name", "likelihood") == "likelihood"
    y = np.array([c["loglik"] if use_ll else -c["histogram_distance"] for c in result["criterion"]])
    return y, "log-likelihood (nats)" if use_ll else "- histogram distance"


def _line_panel(ax, result, truth) -> None:
    """The criterion along the (first) parameter, the estimate, its interval and the truth."""
    import numpy as np

    name = next(iter(result["estimate"]))
    x = np.array([c[name] for c in result["criterion"]])
    y, label = _criterion(result)
    ax.plot(x, y, "o-", color="tab:blue")
    est = result["estimate"][name]
    ax.axvline(est, color="tab:red", label=f"estimate {est:.3f}")
    iv = (result.get("interval_90") or {}).get(name)
    if iv:
        ax.axvspan(iv[0], iv[1], color="tab:red", alpha=0.15, label=f"90% interval {iv[0]:.3f}..{iv[1]:.3f}")
    if truth is not None:
        ax.axvline(truth, color="k", ls="--", label=f"truth {truth:g}")
    ax.set_xlabel(name)
    ax.set_ylabel(label)
    ax.set_title("criterion over the range" + (" (best at the edge)" if result.get("at_edge") else ""))
    ax.legend(fontsize=8)


def _pair_panel(ax, result, truth) -> None:
    """Heat map of the criterion below its best over the pair's grid (interpolated on its
    Delaunay triangles), the grid's points, the diagonal mu_s = mu_k, the estimate and intervals."""
    import matplotlib.patches as mpatches
    import numpy as np

    k = np.array([c["mu_k"] for c in result["criterion"]])
    s = np.array([c["mu_s"] for c in result["criterion"]])
    y, label = _criterion(result)
    drop = np.maximum(y - y.max(), -max(20.0, float(np.percentile(y.max() - y, 50))))
    if len(k) >= 3:
        art = ax.tripcolor(k, s, drop, shading="gouraud", cmap="viridis")
    else:
        art = ax.scatter(k, s, c=drop, cmap="viridis")
    ax.figure.colorbar(art, ax=ax, label=f"{label} below the best (clipped)")
    ax.plot(k, s, ".", color="w", ms=3)
    lo, hi = min(k.min(), s.min()), max(k.max(), s.max())
    ax.plot([lo, hi], [lo, hi], color="w", lw=0.8, ls=":", label="mu_s = mu_k")
    est = result["estimate"]
    ax.plot(est["mu_k"], est["mu_s"], "o", color="tab:red", label=f"estimate {est['mu_s']:.3f}/{est['mu_k']:.3f}")
    iv = result.get("interval_90")
    if iv:
        ax.add_patch(mpatches.Rectangle((iv["mu_k"][0], iv["mu_s"][0]), iv["mu_k"][1] - iv["mu_k"][0],
                                        iv["mu_s"][1] - iv["mu_s"][0], fill=False, ec="tab:red",
                                        label="90% intervals"))
    if truth is not None:
        ts, tk = truth
        ax.plot(tk, ts, "x", color="k", ms=8, label=f"truth {ts:g}/{tk:g}")
    ax.set_xlabel("mu_k (kinetic)")
    ax.set_ylabel("mu_s (static)")
    ax.set_title("criterion over the pair" + (" (best at the edge)" if result.get("at_edge") else ""))
    ax.legend(fontsize=7, loc="lower right")

"""The fit's figure: the criterion over the range, and the log's entropy beside the fitted model's."""
from __future__ import annotations

__all__ = ["fit_figure"]


def fit_figure(result: dict, path, truth: float | None = None) -> str:
    """Write the two-panel figure of a ``kruskal fit`` result (its ``to_dict``) to ``path`` (PNG).

    Left: the criterion at every grid point (log-likelihood, or minus the histogram distance),
    the estimate and its 90% interval (and ``truth`` when known). Right: the log's entropy curve
    against the fitted model's prediction with its 90% band for a log of this size.

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

    name = next(iter(result["estimate"]))
    crit = result["criterion"]
    x = np.array([c[name] for c in crit])
    use_ll = result.get("criterion_name", "likelihood") == "likelihood"
    y = np.array([c["loglik"] if use_ll else -c["histogram_distance"] for c in crit])
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    a1.plot(x, y, "o-", color="tab:blue")
    est = result["estimate"][name]
    a1.axvline(est, color="tab:red", label=f"estimate {est:.3f}")
    iv = (result.get("interval_90") or {}).get(name)
    if iv:
        a1.axvspan(iv[0], iv[1], color="tab:red", alpha=0.15, label=f"90% interval {iv[0]:.3f}..{iv[1]:.3f}")
    if truth is not None:
        a1.axvline(truth, color="k", ls="--", label=f"truth {truth:g}")
    a1.set_xlabel(name)
    a1.set_ylabel("log-likelihood (nats)" if use_ll else "- histogram distance")
    a1.set_title("criterion over the range" + (" (best at the edge)" if result.get("at_edge") else ""))
    a1.legend(fontsize=8)
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

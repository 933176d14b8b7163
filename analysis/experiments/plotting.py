"""Figure helpers of the experiments, in the paper's style (thin lines: single sequences or parts;
bold red: mean; shaded blue: interquartile range; green: the best sequence). Files only, nothing shown."""
from __future__ import annotations

import os

import numpy as np

__all__ = ["pyplot", "save", "trend_axes"]


def pyplot():
    """matplotlib's pyplot on the file-only Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def trend_axes(ax, thin, mean, q25, q75, title, best=None, thin_label="sequence"):
    """Entropy curves on ``ax``: ``thin`` ones, the interquartile band, the mean and ``best``."""
    x = np.arange(len(mean))
    for i, c in enumerate(thin):
        ax.plot(x, c, color="black", lw=0.5, alpha=0.5, label=thin_label if i == 0 else None)
    ax.fill_between(x, q25, q75, color="tab:blue", alpha=0.3, label="interquartile range")
    ax.plot(x, mean, color="tab:red", lw=2.5, label="mean")
    if best is not None:
        ax.plot(x, best, color="tab:green", lw=2, label="best sequence")
    ax.set_xlabel("tilt")
    ax.set_ylabel("entropy (bits)")
    ax.set_title(title, fontsize=10)
    ax.set_ylim(bottom=-0.05)
    ax.legend(fontsize=7)


def save(fig, out_dir, name) -> list[str]:
    """Write ``fig`` atomically as ``out_dir/name``, close it; return ``[path]``."""
    path = os.path.join(out_dir, name)
    tmp = path + ".tmp.png"
    fig.savefig(tmp, dpi=110, bbox_inches="tight")
    os.replace(tmp, path)
    pyplot().close(fig)
    return [path]

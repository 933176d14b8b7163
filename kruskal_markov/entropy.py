"""Entropy of distributions and histograms (bits, plug-in Shannon estimate, 0 log 0 = 0)."""
from __future__ import annotations

import numpy as np


def histogram_entropy_bits(counts) -> float:
    """Plug-in Shannon entropy, in bits, of a histogram of non-negative counts.

    Empty bins contribute nothing (0 log 0 = 0). An all-zero histogram has entropy 0.

    >>> histogram_entropy_bits([5, 5, 0, 0])
    1.0
    """
    c = np.asarray(counts, dtype=np.float64).ravel()
    if c.size and (not np.all(np.isfinite(c)) or np.any(c < 0)):
        raise ValueError("histogram counts must be finite and non-negative")
    total = c.sum()
    if total <= 0:
        return 0.0
    p = c[c > 0] / total
    return float(max(0.0, -np.sum(p * np.log2(p))))

"""A tray's physics from a pose log: ``kruskal fit`` (docs/fit.md).

Modules, one topic each: :mod:`~analysis.fit.log` (reading and checking a log),
:mod:`~analysis.fit.hmm` (every trial's likelihood under a model, the forward algorithm),
:mod:`~analysis.fit.histograms` (the likelihood-free baseline and the entropy band),
:mod:`~analysis.fit.goodness` (the goodness of fit's verdict),
:mod:`~analysis.fit.design` (``fit --design``: the calibration experiment),
:mod:`~analysis.fit.core` (the grid of models, the estimate and its interval),
:mod:`~analysis.fit.pair` (the static/kinetic pair's 2-D grid, estimate and intervals),
:mod:`~analysis.fit.figure` (the criterion and goodness-of-fit figure) and
:mod:`~analysis.fit.study` (the report's "A tray's log").
"""
from analysis.fit.core import FitResult, FitSettings, fit_log
from analysis.fit.log import FitLog, read_fit_log

__all__ = ["FitLog", "FitResult", "FitSettings", "fit_log", "read_fit_log"]

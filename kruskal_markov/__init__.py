"""Pure mathematics of the tray model: transition models, entropy, ensembles, synchronization.

Imports numpy, scipy, numba and networkx only -- never pybullet, ``transition_builder`` or ``analysis``.
"""

"""The planar engine: the tray-tilt physics of a flat part in compiled code (Numba).

:class:`PlanarSimulator` has the interface of :class:`transition_builder.sim.TraySimulator` (a batch
of start poses and one action in, rest poses and fault codes out); ``SimSettings.engine = "planar"``
selects it everywhere (:func:`transition_builder.simulators.make_simulator`). docs/simulator.md, "The
planar engine", says what it computes and how it was judged against PyBullet.
"""
from transition_builder.planar.simulator import PlanarSimulator

__all__ = ["PlanarSimulator"]

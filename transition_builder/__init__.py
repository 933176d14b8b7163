"""From physics to a transition model: scenes, shapes, the PyBullet tray-tilt simulator, grids.

The only package that imports pybullet.
"""

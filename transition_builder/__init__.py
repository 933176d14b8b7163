"""From physics to a transition model: scenes, shapes, the PyBullet tray-tilt simulator, grids.

The only package that imports pybullet.

The API by topic
----------------
Scenes and shapes
    :class:`Scene`, :func:`scene_from_options`, :data:`ACTIONS`, :class:`Shape`,
    :func:`parse_shape`, :func:`allen_key`, :func:`random_triangle`, :func:`rectangle`,
    :func:`make_shape`, :func:`parse_friction`, :class:`SimSettings`.
Simulation
    :class:`TraySimulator`, :func:`simulate`, :func:`parse_noise` (process noise).
Grids
    :class:`ReportGrid`, :func:`parse_grid`.
Building models
    :func:`build_model`, :class:`BuildSettings`, :class:`BuildResult` (``transition_builder.builder``,
    one module per phase), :func:`cached_build` (models under a content hash).
"""
from kruskal_markov.lazy import lazy_exports

#: public name -> the module that defines it (imported on first use, so that ``import transition_builder`` and
#: the command line stay fast; PEP 562).
_EXPORTS = {
    "Scene": "scene",
    "scene_from_options": "scene",
    "ACTIONS": "scene",
    "Shape": "shapes",
    "parse_shape": "shapes",
    "allen_key": "shapes",
    "random_triangle": "shapes",
    "rectangle": "shapes",
    "make_shape": "shapes",
    "SimSettings": "sim_settings",
    "TraySimulator": "sim",
    "simulate": "simulators",
    "ReportGrid": "grid",
    "parse_grid": "grid",
    "parse_friction": "friction",
    "parse_noise": "noise",
    "BuildSettings": "builder",
    "BuildResult": "builder",
    "build_model": "builder",
    "cached_build": "cache",
}
__all__ = sorted(_EXPORTS)

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

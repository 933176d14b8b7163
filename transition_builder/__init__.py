"""From physics to a transition model: scenes, shapes, the PyBullet tray-tilt simulator, grids.

The only package that imports pybullet.
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
    "SimSettings": "settings",
    "TraySimulator": "sim",
    "simulate": "sim",
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

"""What users run: the ``kruskal`` command line, direct simulation, experiments, figures and reports."""


#: public name -> the module that defines it (imported on first use, so that ``import analysis`` and
#: the command line stay fast; PEP 562).
_EXPORTS = {
    "run_direct": "montecarlo",
    "DirectResult": "montecarlo",
    "read_poses_csv": "montecarlo",
    "write_poses_csv": "montecarlo",
    "entropy_by_step": "montecarlo",
    "validate_model": "validate",
    "random_sequences_for": "sequences",
    "PartMetrics": "orientability",
    "part_metrics": "orientability",
    "rank_parts": "orientability",
    "ReproduceSettings": "reproduce",
    "reproduce": "reproduce",
    "write_report": "report",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        import importlib

        value = getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))

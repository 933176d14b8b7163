"""The test suite, one package per source package (``tests/kruskal_markov/sync/test_exact.py`` tests
``kruskal_markov/sync/exact.py``); ``tests/contract/`` holds the cross-cutting checks (bad input on
every command, the packaged wheel, docstrings and their examples, the README's figures).

:data:`ROOT` is the repository and :data:`DATA` the tests' data files, wherever a test module sits.
"""
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"

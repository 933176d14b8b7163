"""Tests of the benchmarks' own machinery (``make bench-test``); the product's suite is ``tests/``."""

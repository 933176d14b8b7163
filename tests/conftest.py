"""Shared pytest configuration. Fixtures live in the test module that uses them.

Hypothesis runs derandomized by default (profile ``ci``): the same examples on every run and every
machine, so a failure in CI reproduces locally. ``HYPOTHESIS_PROFILE=explore`` draws fresh random
examples (more of them) to look for new failures; a failing example is printed with its
``@reproduce_failure`` blob.
"""
import os

from hypothesis import settings

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("explore", deadline=None, print_blob=True, max_examples=500)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

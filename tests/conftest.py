"""Shared pytest configuration. Fixtures live in the test module that uses them."""

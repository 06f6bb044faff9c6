"""Shared pytest configuration.

``@pytest.mark.full``: a test that repeats what a shorter one checks (more signals, another kill)
and runs only with ``PMMW_TEST_FULL=1`` (``make test-full``), keeping ``make test`` under 10
minutes on 2 cores.
"""

import os

import pytest

FULL = os.environ.get("PMMW_TEST_FULL") == "1"


def pytest_collection_modifyitems(config, items):
    if FULL:
        return
    skip = pytest.mark.skip(reason="repeats a shorter test: PMMW_TEST_FULL=1 (make test-full) runs it")
    for item in items:
        if "full" in item.keywords:
            item.add_marker(skip)

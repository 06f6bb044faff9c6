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


@pytest.fixture(autouse=True)
def _render_outcome():
    """Each test starts with the interrupt line of a render, as each `pmmw` process does
    (`interrupt.run`): tests invoke several commands in one process, and ``pmmw po`` sets its own
    line (`interrupt.outcome`), which a later test's interrupted render then printed instead of
    its ``--resume`` hint (tests/cli/test_cli.py after tests/physical_optics/test_po.py in one
    worker)."""
    from pmmw import interrupt

    interrupt.outcome(interrupt.RENDER_OUTCOME)
    yield

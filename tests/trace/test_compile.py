"""The tracer's kernels compiled in two processes (`pmmw.trace.compile`): the two groups together
cover every kernel `kernels.warm` compiles, so that neither process compiles the other's."""

import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

# In a fresh process (nothing compiled or loaded yet), the compiled functions that `kernels.warm`
# asks numba for (compiled or loaded from the cache: both go through `Dispatcher.compile`) while
# the names given are stubbed; printed one per line.
_ASKED = """
import sys
from numba.core.dispatcher import Dispatcher
from pmmw.trace import compile as c, kernels
asked = []
real = Dispatcher.compile
def spy(self, sig):
    asked.append(self.py_func.__qualname__)
    return real(self, sig)
Dispatcher.compile = spy
keep = sys.argv[1:]
names = [n for n in c.CHILD + c.PARENT if n[1] not in keep]
with c.stubbed(names):
    kernels.warm(8, rough=True)
print("\\n".join(sorted(set(asked))))
"""


def _asked(*keep):
    out = subprocess.run(
        [sys.executable, "-c", _ASKED, *keep], capture_output=True, text=True, check=True, cwd=REPO, timeout=600
    )
    return out.stdout.split()


def test_the_two_groups_cover_every_kernel_warm_compiles():
    # with both groups stubbed, `warm` asks numba for nothing: every kernel it compiles is in
    # exactly one process's group. The control: `stderr` (the cheapest kernel) left unstubbed is asked for.
    assert _asked() == []
    assert _asked("stderr") == ["stderr"]


def test_the_groups_are_disjoint_and_exist():
    from pmmw.trace import compile as c

    assert not set(c.CHILD) & set(c.PARENT)
    for mod, attr in c.CHILD + c.PARENT:
        __import__(mod)
        assert hasattr(sys.modules[mod], attr), (mod, attr)


def test_stubbed_restores_every_name():
    from pmmw.trace import compile as c
    from pmmw.trace import kernels

    before = kernels.scatter
    with pytest.raises(RuntimeError), c.stubbed(c.PARENT):
        assert kernels.scatter is not before
        raise RuntimeError
    assert kernels.scatter is before

"""`pmmw brdf`'s Monte Carlo (`pmmw.reflectance.montecarlo`) does not depend on its chunk size:
sample i draws from the key of (seed, i) (`pmmw.rng.ray_keys`), whatever chunk it is traced in."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pmmw import reflectance as B
from pmmw.physics import roughness as R
from pmmw.reflectance import montecarlo

SAMPLES = 3000
U = 2.0**-53  # float64's unit roundoff
# Terms of any one sum, at most: a sample's deposits (two columns) and its cut power, and the
# Jones entries (4) of its children into the substrate, counted generously.
TERMS = 16 * SAMPLES
# Two sums of the same terms in different orders are each within gamma_(n-1) sum|x_i| of the exact
# sum, whatever the order (Higham 2002, sec. 4.2): so within twice that of each other.
GAMMA = 2.0 * TERMS * U / (1.0 - TERMS * U)

STACKS = {
    # a lossy rough coating layer over rough copper: the layer walk, absorption, roulette
    "lossy": B.Stack(
        layers=(
            B.StackLayer(eps=2.5 + 0.05j, thickness=2e-3, roughness=R.AshikhminShirley(10, 10)),
            B.StackLayer(eps=(0.23 + 3.46j) ** 2, roughness=R.AshikhminShirley(20, 20)),
        ),
        frequency=95e9,
    ),
    # three lossless rough interfaces (GGX at the bottom: its facet draw and masking): transmission
    "lossless": B.Stack(
        layers=(
            B.StackLayer(eps=1.69 + 0j, roughness=R.AshikhminShirley(30, 30)),
            B.StackLayer(eps=1.96 + 0j, roughness=R.AshikhminShirley(10, 40, orientation_deg=30)),
            B.StackLayer(eps=2.25 + 0j, roughness=R.GGX(0.3)),
        )
    ),
}


def _tally(stack, seed):
    wi = np.array([math.sin(math.radians(40.0)), 0.0, math.cos(math.radians(40.0))])
    return montecarlo.monte_carlo(stack, wi, np.array([1.0, 1.0, 0.0, 0.0]), samples=SAMPLES, seed=seed)


def _apart(a, b) -> list[str]:
    """The fields of two tallies that differ by more than reordering their sums can make them:
    the counts exactly; each sum by GAMMA times the sum of its terms' magnitudes, bounded from
    `a` (every term of ``i_sum``, ``i_sq``, ``transmitted``, ``lost`` is >= 0; ``absorbed`` is the
    deposits, >= 0, less ``lost``; a Mueller matrix's elements are at most its m00, >= 0)."""
    out = [f for f in ("events", "fallback_weights") if getattr(a, f) != getattr(b, f)]
    scale = {"i_sum": a.i_sum, "i_sq": a.i_sq, "transmitted": a.transmitted, "lost": a.lost}
    scale["absorbed"] = abs(a.absorbed) + 2.0 * a.lost
    out += [f for f, s in scale.items() if abs(getattr(a, f) - getattr(b, f)) > GAMMA * s]
    if np.any(np.abs(a.by_order - b.by_order) > GAMMA * a.by_order[..., :1, :1]):
        out.append("by_order")
    return out


@pytest.mark.parametrize("name", STACKS)
def test_the_result_does_not_depend_on_the_chunk_size(name, monkeypatch):
    """3000 samples in one chunk (the default, 2**17) and in chunks of 256 (the last one partial):
    the counts of facet events and fallbacks are equal and every sum equal to within the rounding
    of adding the same terms in another order (``GAMMA``, 1.1e-11 of the sum of magnitudes): no
    sample's numbers changed with its chunk. The control: seed + 1 differs in the sums and the
    Mueller maps by far more (about 1e-3)."""
    one = _tally(STACKS[name], 5)
    monkeypatch.setattr(montecarlo, "_CHUNK", 256)
    chunked = _tally(STACKS[name], 5)
    assert _apart(one, chunked) == []
    assert {"i_sum", "by_order"} <= set(_apart(one, _tally(STACKS[name], 6)))  # control

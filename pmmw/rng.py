"""Every random number of a ray, counter-based: a hash of the ray's identity, not a draw from a
generator that other rays also draw from.

A counter-based generator (Salmon et al. 2011) maps a key and a counter to a random number by a
hash, so a number depends on nothing but what it is for. Here the hash is the splitmix64
finalizer (Steele et al. 2014, its ``mix64``: the constants ``0xBF58476D1CE4E5B9`` and
``0x94D049BB133111EB`` with shifts 30, 27, 31, after adding the golden gamma
``0x9E3779B97F4A7C15``); all arithmetic is modulo 2**64.

* Each ray carries a 64-bit ``key`` (`pmmw.surface.Wave`): a camera ray's is `ray_keys` of the
  render seed and its (pixel, sample) number; a child's is `child_key1` of its parent's key and
  its `Branch` (reflected, transmitted; a ray that crosses a face without interacting takes the
  ``PASSED`` branch), so the two children of a split interaction, and every step of a re-hit
  chain or a layer walk, draw different numbers.
* A uniform is ``uniform1(key, depth, purpose)``: the hash of the key with (depth, `Purpose`), its
  top 53 bits over 2**53, in [0, 1).

A ray's numbers therefore depend on its identity only: not on the order of other draws, the tile
size or the worker count. The camera's own streams (`pmmw.scene.camera`: the per-pixel rotation of
the R2 sequence and the thin lens) use `hash_uniform1` of (seed, pixel key, stream), the streams
being `Purpose` ``PIXEL_U`` .. ``LENS_PHI``. Generators of scene inputs (the Gaussian bump
surfaces, `pmmw.scene.bump`) keep their own seeded NumPy generators.
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np

from pmmw.jit import inline, njit

__all__ = [
    "Branch",
    "Purpose",
    "child_key1",
    "child_keys",
    "hash_uniform1",
    "ray_keys",
    "splitmix64",
    "uniform1",
    "uniforms",
]

GOLDEN = np.uint64(0x9E3779B97F4A7C15)
MIX1 = np.uint64(0xBF58476D1CE4E5B9)
MIX2 = np.uint64(0x94D049BB133111EB)
_FNV = np.uint64(0x100000001B3)
_BRANCH_TAG = np.uint64(1 << 63)  # a child's hash input: never a (depth, purpose) input below 2**40
_TO_UNIT = 1.0 / 9007199254740992.0  # 2**-53


class Purpose(IntEnum):
    """What a uniform is for: the counter of `uniform1` (with the ray's depth)."""

    PIXEL_U = 1  #: the camera's per-pixel rotation of the R2 sequence, u and v
    PIXEL_V = 2
    LENS_R = 3  #: the thin lens's radius and angle
    LENS_PHI = 4
    ARRIVAL_ROULETTE = 5  #: Russian roulette where a segment's absorption left the ray (`kernels.arrive`)
    BRANCH_CHOICE = 6  #: reflected or transmitted child (``stochastic``, ``hybrid``)
    ROULETTE_REFLECTED = 7  #: Russian roulette of the children as they leave the surface
    ROULETTE_TRANSMITTED = 8
    FACET_U1 = 9  #: the microfacet normal's draw
    FACET_U2 = 10
    MASKING_REFLECTED = 11  #: whether a child on a rough face is masked by the microsurface
    MASKING_TRANSMITTED = 12
    SURVIVAL = 13  #: Russian roulette after the depth cut-off and weight threshold (`kernels.survivors`)


class Branch(IntEnum):
    """How a ray's key becomes its child's (`child_key1`)."""

    REFLECTED = 0
    TRANSMITTED = 1
    PASSED = 2  #: crossed a face without interacting (`kernels.arrive`'s ``PASSED``)


@inline()
def splitmix64(x):
    """The splitmix64 finalizer of one uint64 (Steele et al. 2014; arithmetic wraps mod 2**64)."""
    x = x + GOLDEN
    x = (x ^ (x >> np.uint64(30))) * MIX1
    x = (x ^ (x >> np.uint64(27))) * MIX2
    return x ^ (x >> np.uint64(31))


@inline()
def _key1(seed, ident, stream):
    return splitmix64(np.uint64(ident) ^ splitmix64(np.uint64(seed) * _FNV + np.uint64(stream)))


@inline()
def hash_uniform1(seed, key, stream):
    """A uniform [0, 1) float from the hash of (seed, stream, key): the camera's streams."""
    return float(_key1(seed, key, stream) >> np.uint64(11)) * _TO_UNIT


@inline()
def child_key1(key, branch):
    """The key of a child of the ray of key ``key`` (uint64) along ``branch`` (`Branch`)."""
    return splitmix64(key ^ splitmix64(_BRANCH_TAG | np.uint64(branch)))


@inline()
def uniform1(key, depth, purpose):
    """The uniform [0, 1) of the ray of key ``key`` (uint64) at ``depth`` for ``purpose``."""
    h = splitmix64(key ^ splitmix64((np.uint64(depth) << np.uint64(8)) | np.uint64(purpose)))
    return float(np.int64(h >> np.uint64(11))) * _TO_UNIT  # (signed: a faster conversion, exact below 2**53)


@njit()
def _ray_keys(seed, ids, out):
    for i in range(ids.shape[0]):
        out[i] = _key1(seed, ids[i], 0)


@njit()
def _child_keys(keys, branch, out):
    for i in range(keys.shape[0]):
        out[i] = child_key1(keys[i], branch)


@njit()
def _uniforms(keys, depth, purposes, out):
    for i in range(keys.shape[0]):
        for j in range(purposes.shape[0]):
            out[i, j] = uniform1(keys[i], depth[i], purposes[j])


def ray_keys(seed: int, ids) -> np.ndarray:
    """The keys (uint64, shape of ``ids``) of the rays numbered ``ids`` (int64; a camera ray's is
    pixel * spp + sample) of a render of seed ``seed``."""
    k = np.ascontiguousarray(ids, dtype=np.int64)
    out = np.empty(k.shape, np.uint64)
    _ray_keys(np.int64(seed), k.reshape(-1), out.reshape(-1))
    return out


def child_keys(keys, branch: int) -> np.ndarray:
    """`child_key1` of each key (uint64 array) along ``branch`` (`Branch`)."""
    keys = np.ascontiguousarray(keys, dtype=np.uint64)
    out = np.empty_like(keys)
    _child_keys(keys, np.int64(branch), out)
    return out


def uniforms(keys, depth, *purposes: int) -> np.ndarray:
    """Uniforms in [0, 1) of the rays of keys ``keys`` (uint64, (n,)) at depths ``depth`` (int,
    (n,)): shape (n,) for one purpose, (n, len(purposes)) for several (`uniform1`)."""
    keys = np.ascontiguousarray(keys, dtype=np.uint64)
    depth = np.ascontiguousarray(depth, dtype=np.int32)
    out = np.empty((keys.shape[0], len(purposes)))
    _uniforms(keys, depth, np.array(purposes, np.int64), out)
    return out[:, 0] if len(purposes) == 1 else out

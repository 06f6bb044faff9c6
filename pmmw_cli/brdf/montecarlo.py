"""Optics Express 2016's Monte Carlo over a rough layered surface (`pmmw_cli.brdf` docstring, ``mc``):
a wavefront of paths, each carrying a Jones matrix, followed facet by facet until it leaves the
top surface and is binned on the grid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pmmw_cli.brdf.grid import N_PHI, N_THETA, _cells, _hv, mueller_from_jones
from pmmw_cli.brdf.optics import _TINY, _amplitude, _facet_basis, _Interface, _refract
from pmmw_cli.brdf.stack import Stack
from pmmw_cli.physics import roughness as rough
from pmmw_cli.physics.jones import basis_change
from pmmw_cli.physics.vec import cross, dot

__all__ = ["monte_carlo"]

# Paths are followed in chunks of this many rays (memory, not results: chunks have own seeds).
_CHUNK = 1 << 17
# Facet interactions after which a path is ended and counted as lost (never reached in practice:
# reported in the summary as ``lost``).
_MAX_EVENTS = 1000


@dataclass
class _Paths:
    """Struct of arrays of live paths."""

    d: np.ndarray        # (n, 3) propagation direction
    s: np.ndarray        # (n, 3) current basis
    p: np.ndarray        # (n, 3) p = d x s
    j: np.ndarray        # (n, 2, 2) complex: incident (h, v) -> current (s, p)
    itf: np.ndarray      # (n,) interface index of the next interaction
    above: np.ndarray    # (n,) bool: the ray meets it from above
    order: np.ndarray    # (n,) facet interactions so far
    rehits: np.ndarray   # (n,) consecutive re-hits

    def take(self, idx):
        return _Paths(*(getattr(self, f)[idx] for f in self.__dataclass_fields__))

    @staticmethod
    def concat(parts):
        parts = [p for p in parts if p is not None and p.d.shape[0]]
        if not parts:
            return None
        return _Paths(*(np.concatenate([getattr(p, f) for p in parts]) for f in _Paths.__dataclass_fields__))


@dataclass
class _Tally:
    by_order: np.ndarray                 # (3, 91, 360, 4, 4) summed path Mueller, orders 1, 2, >= 3
    i_sum: float = 0.0                   # sum over paths of reflected I (for S_in)
    i_sq: float = 0.0                    # sum of squares (standard error)
    transmitted: float = 0.0             # unpolarized power into a lossless substrate
    absorbed: float = 0.0                # at interfaces, in sinks, in layers, ended re-hit chains
    lost: float = 0.0                    # paths ended at _MAX_EVENTS
    events: int = 0
    fallback_weights: int = 0            # rejection fallbacks (roughness module)


def monte_carlo(stack: Stack, wi, stokes_in, *, samples=1_000_000, seed=0, threshold=1e-3):
    """Optics Express 2016's Monte Carlo over a rough layered surface (`pmmw_cli.brdf` docstring).

    Parameters
    ----------
    stack : Stack
    wi : ndarray, shape (3,), float64
        Unit direction toward the source (wi.z > 0).
    stokes_in : ndarray, shape (4,), float64
        Incident Stokes vector in the incident (h, v) basis (only for ``i_sum``/standard error;
        the Mueller matrix is independent of it).
    samples : int
        Incident rays.
    seed : int
        Run seed; chunk c uses ``SeedSequence([seed, c])``.
    threshold : float
        Russian roulette below this unpolarized path power (survivors scaled up: unbiased).

    Returns
    -------
    _Tally
        Sums over paths (divide by ``samples`` for fractions of the incident power).
    """
    interfaces = [_Interface(stack, i) for i in range(len(stack.layers))]
    tally = _Tally(by_order=np.zeros((3, N_THETA, N_PHI, 4, 4)))
    phi_i = math.atan2(wi[1], wi[0])
    k_in = -np.asarray(wi, dtype=np.float64)
    h_in, v_in = _hv(k_in[None, :], np.array([phi_i + math.pi]))
    for c, start in enumerate(range(0, samples, _CHUNK)):
        n = min(_CHUNK, samples - start)
        rng = np.random.default_rng(np.random.SeedSequence([int(seed), c]))
        j0 = np.zeros((n, 2, 2), dtype=np.complex128)
        j0[:, 0, 0] = j0[:, 1, 1] = 1.0
        paths = _Paths(d=np.tile(k_in, (n, 1)), s=np.tile(h_in[0], (n, 1)), p=np.tile(v_in[0], (n, 1)), j=j0,
                       itf=np.zeros(n, np.int64), above=np.ones(n, bool), order=np.zeros(n, np.int64),
                       rehits=np.zeros(n, np.int64))
        while paths is not None:
            nxt = []
            for i, itf in enumerate(interfaces):
                for from_above in (True, False):
                    sel = np.nonzero((paths.itf == i) & (paths.above == from_above))[0]
                    if sel.size:
                        nxt.append(_mc_event(paths.take(sel), itf, i, from_above, stack, rng, tally, stokes_in,
                                             threshold))
            paths = _Paths.concat(nxt)
    return tally


def _mc_event(pt: _Paths, itf: _Interface, i: int, from_above: bool, stack, rng, tally: _Tally, stokes_in,
              threshold):
    """One facet interaction for paths meeting interface i from one side; returns survivors."""
    n = pt.d.shape[0]
    tally.events += n
    n_x = np.array([0.0, 0.0, 1.0 if from_above else -1.0])  # macro normal on the rays' side
    tangent = np.array([1.0, 0.0, 0.0])
    wo = -pt.d
    u = rng.random((n, 4))
    # 1. facet normal (roughness module, "How the renderer uses this")
    if itf.model is not None:
        m, w = itf.model.sample_normals(n_x, tangent, wo, u[:, 0], u[:, 1])
        fb = w != 1.0
        if np.any(fb):
            tally.fallback_weights += int(fb.sum())
            # weight 0: no facet faces the ray; it ends absorbed at the surface
            tally.absorbed += 0.5 * float(np.sum(np.abs(pt.j[w == 0.0]) ** 2))
            pt.j = pt.j * np.sqrt(w)[:, None, None]
    else:
        m = np.tile(n_x, (n, 1))
    # 2. Fresnel about the facet, in the facet's (s, p) basis
    cos1 = np.clip(dot(wo, m), 0.0, 1.0)
    co = itf.fresnel(cos1, from_above)
    s_loc, p_in = _facet_basis(m, pt.d, pt.s)
    jl = basis_change(s_loc, p_in, pt.s, pt.p) @ pt.j
    p_before = np.sum(np.abs(pt.j) ** 2, axis=(1, 2))
    ars, arp = _amplitude(co.rs, co.Rs), _amplitude(co.rp, co.Rp)
    ats, atp = _amplitude(co.ts, co.Ts), _amplitude(co.tp, co.Tp)
    jr = jl * np.stack([ars, arp], axis=1)[:, :, None]
    jt = jl * np.stack([ats, atp], axis=1)[:, :, None]
    pr = np.sum(np.abs(jr) ** 2, axis=(1, 2))
    ptr = np.sum(np.abs(jt) ** 2, axis=(1, 2))
    eps_from, eps_to = (itf.above, itf.below) if from_above else (itf.below, itf.above)
    into_sink = itf.sink and from_above
    if into_sink:
        # what enters an absorbing substrate stays there: keep only the reflected child
        tally.absorbed += 0.5 * float(np.sum(p_before - pr))
        take_r = np.ones(n, bool)
        gain = np.ones(n)
    else:
        tally.absorbed += 0.5 * float(np.sum(np.maximum(p_before - pr - ptr, 0.0)))
        tot = pr + ptr
        prob_r = np.where(tot > 0.0, pr / np.where(tot > 0.0, tot, 1.0), 1.0)
        take_r = u[:, 2] < prob_r
        gain = np.sqrt(np.where(take_r, tot / np.maximum(pr, _TINY), tot / np.maximum(ptr, _TINY)))
    alive = np.where(take_r, pr, ptr) > 0.0
    j_new = np.where(take_r[:, None, None], jr, jt) * gain[:, None, None]
    d_r = pt.d - 2.0 * dot(pt.d, m)[:, None] * m
    d_new = d_r.copy()
    if np.any(~take_r):
        t_idx = np.nonzero(~take_r)[0]
        d_new[t_idx] = _refract(pt.d[t_idx], m[t_idx], eps_from, eps_to)
    p_new = cross(d_new, s_loc)
    # 3. side of the child and masking
    child_above = np.where(take_r, from_above, not from_above)  # side it is on (above the interface?)
    n_side = np.where(child_above[:, None], np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -1.0]))
    if itf.model is not None:
        leave_p = itf.model.masking(n_side, tangent, d_new)
    else:
        leave_p = (dot(d_new, n_side) > 0.0).astype(np.float64)
    leave = u[:, 3] < leave_p
    order = pt.order + 1
    rehits = np.where(leave, 0, pt.rehits + 1)
    new = _Paths(d=d_new, s=s_loc, p=p_new, j=j_new, itf=np.full(n, i), above=child_above, order=order, rehits=rehits)
    # ended re-hit chains: absorbed at the surface (roughness.MAX_REHITS)
    chain_end = ~leave & (rehits > rough.MAX_REHITS)
    if np.any(chain_end):
        tally.absorbed += 0.5 * float(np.sum(np.abs(j_new[chain_end]) ** 2))
    keep = alive & ~chain_end
    out = []
    # re-hits: same interface, from the child's side, after one wavelength of the medium there
    # (the shortest way to another facet for which geometrical optics holds; the renderer's rule)
    rh = keep & ~leave
    if np.any(rh):
        back = new.take(np.nonzero(rh)[0])
        # only where absorption is modelled: a layer with a thickness (Optics Express 2016 assumption 3)
        lay_above = stack.layers[i - 1] if i > 0 else None
        lossy_above = lay_above is not None and lay_above.thickness is not None
        lossy_below = stack.layers[i].thickness is not None and not itf.last
        if stack.k0 is not None and (lossy_above or lossy_below):
            eps_side = np.where(back.above, itf.above if lossy_above else 1.0, itf.below if lossy_below else 1.0)
            tau = np.exp(-4.0 * math.pi * np.sqrt(eps_side + 0j).imag)  # exp(-alpha lambda), alpha = 2 k0 Im n
            if np.any(tau < 1.0):
                before = 0.5 * np.sum(np.abs(back.j) ** 2, axis=(1, 2))
                back.j = back.j * np.sqrt(tau)[:, None, None]
                tally.absorbed += float(np.sum(before * (1.0 - tau)))
        out.append(back)
    lv = keep & leave
    if np.any(lv):
        go = new.take(np.nonzero(lv)[0])
        up = go.above  # it leaves into the medium above interface i
        if np.any(up):
            if i == 0:
                _collect(go.take(np.nonzero(up)[0]), tally, stokes_in)
            else:
                g = go.take(np.nonzero(up)[0])
                g.itf = g.itf - 1
                g.above = np.zeros(g.d.shape[0], bool)  # meets the interface above from below
                out.append(_travel(g, stack, i, tally))
        if np.any(~up):
            g = go.take(np.nonzero(~up)[0])
            if itf.last:
                tally.transmitted += 0.5 * float(np.sum(np.abs(g.j) ** 2))
            else:
                g.itf = g.itf + 1
                g.above = np.ones(g.d.shape[0], bool)
                out.append(_travel(g, stack, i + 1, tally))
    surv = _Paths.concat(out)
    if surv is None:
        return None
    # depth cap and Russian roulette on the unpolarized power
    power = 0.5 * np.sum(np.abs(surv.j) ** 2, axis=(1, 2))
    capped = surv.order >= _MAX_EVENTS
    if np.any(capped):
        tally.lost += float(np.sum(power[capped]))
    low = (power < threshold) & ~capped
    keep = ~capped
    if np.any(low):
        idx = np.nonzero(low)[0]
        q = power[idx] / threshold
        survive = rng.random(idx.size) < q
        surv.j[idx[survive]] /= np.sqrt(q[survive])[:, None, None]
        keep[idx[~survive]] = False
    return surv.take(np.nonzero(keep)[0]) if not np.all(keep) else surv


def _travel(g: _Paths, stack: Stack, layer_index: int, tally: _Tally):
    """Cross layer ``layer_index`` (1-based medium index) to its other interface, absorbing."""
    layer = stack.layers[layer_index - 1]
    eps = stack.media()[layer_index]
    if layer.thickness and eps.imag > 0.0 and stack.k0 is not None:
        alpha = 2.0 * stack.k0 * np.sqrt(eps).imag  # power attenuation [1/m] (PHYSICS.md)
        length = layer.thickness / np.maximum(np.abs(g.d[:, 2]), 1e-12)
        tau = np.exp(-alpha * length)
        before = 0.5 * np.sum(np.abs(g.j) ** 2, axis=(1, 2))
        g.j = g.j * np.sqrt(tau)[:, None, None]
        tally.absorbed += float(np.sum(before * (1.0 - tau)))
    g.rehits = np.zeros_like(g.rehits)
    return g


def _collect(g: _Paths, tally: _Tally, stokes_in):
    """Rays leaving the top surface: rotate to the outgoing (h, v) basis and bin their Mueller."""
    phi = np.arctan2(g.d[:, 1], g.d[:, 0])
    h, v = _hv(g.d, phi)
    j_out = basis_change(h, v, g.s, g.p) @ g.j
    mm = mueller_from_jones(j_out)
    row, col = _cells(g.d)
    flat = row * N_PHI + col
    size = N_THETA * N_PHI
    order = np.clip(g.order, 1, 3) - 1
    for o in range(3):
        sel = order == o
        if np.any(sel):
            tally.by_order[o] += np.stack(
                [np.bincount(flat[sel], weights=mm[sel, a, b], minlength=size) for a in range(4) for b in range(4)],
                axis=-1).reshape(N_THETA, N_PHI, 4, 4)
    i_out = mm[:, 0, :] @ stokes_in
    tally.i_sum += float(i_out.sum())
    tally.i_sq += float((i_out ** 2).sum())

"""What happens where a wave of rays meets faces: one call per bounce (`Surfaces.interact`).

Built once per material table and frequency from the scene's media (`job.Media`: smooth
interfaces, coherent films, rough interfaces, bump maps and rough coating layers, flattened by
`kernel_tables`), it takes the rays of a wave that interact with a face (as `kernels.arrive`
leaves them) and returns their children, adding the emission they deposit (the absorbed power
of interfaces, films and layers, what a sink swallows, and paths ended on a temperature) to the
per-sample sums. Smooth scenes run one compiled pass (`kernels.scatter`); about rough faces and
bump maps the same kernel runs about facets drawn by each face's model, then `kernels.settle`
sends each child off the surface or back onto it (Smith masking); a surface with rough coating
layers is walked through them (Optics Express 2016) by the same two kernels, each rough layer a
medium of the tables. The renderer (`pmmw.trace.integrator`) and `pmmw brdf`'s Monte Carlo
(`pmmw.reflectance.montecarlo`) both trace through it; `pmmw po` takes its reflection coefficients
from the same tables (`surface_coefficients`).
"""

from __future__ import annotations

import numpy as np

from pmmw import rng
from pmmw.constants import C0
from pmmw.physics.roughness import GGX_CODE, MAX_REHITS, OTHER_CODE
from pmmw.rng import Purpose
from pmmw.surface import kernels
from pmmw.surface.media import Media
from pmmw.surface.records import BackSide, ChainEnd, Choice, Fate, Hit, HitCode, LeaveSide
from pmmw.surface.tables import Pile, kernel_tables
from pmmw.surface.wave import Wave

__all__ = ["Surfaces", "deposit"]

_NO_RANDOM = np.zeros(0)  # the kernels' "no uniforms drawn"
_NO_CODE = np.zeros(0, np.int8)  # `kernels.scatter` does not read the codes of `kernels.arrive`
_MAX_WALK = 1000  # facet events of one walk through rough coating layers (never reached in tests)


def deposit(acc, sid, m, ta, tb=None):
    """Add incoherent emission of brightness temperatures ``ta`` (and ``tb`` for the second
    column; default ``ta``) [K], scalars or shape (n,), seen through Jones matrices ``m`` (n, 2, 2)
    (already scaled by emission amplitudes), to ``acc[sid]`` (`kernels.emit`)."""
    n = sid.size
    if n == 0:
        return
    # always C-contiguous and writable: one compiled specialization whether or not they were broadcast
    ta = np.require(np.broadcast_to(np.asarray(ta, float), (n,)), requirements="CW")
    tb = ta if tb is None else np.require(np.broadcast_to(np.asarray(tb, float), (n,)), requirements="CW")
    kernels.emit(acc, np.ascontiguousarray(sid, np.int64), np.ascontiguousarray(m, complex), ta, tb)


class Surfaces:
    """The layered surfaces of a scene at one frequency, and the bounce's interactions with them.

    Parameters
    ----------
    media : job.Media
    frequency : float
        [Hz]
    faces : tuple (face_medium, face_normals, face_offset)
        Per face: the medium index (n_f,) int32, the unit normal (n_f, 3) float64 and the step
        off the surface [m] (n_f,) float64 (`intersect`'s ``face_offset``).
    limits : tuple (max_depth, threshold, roulette, t_lo, t_hi)
        Termination (`kernels.survive`).
    choice : Choice or tuple (strategy code, split_depth)
        Branch choice (`kernels.STRATEGIES`).
    compiled : bool or None
        Smooth scenes interact in one pass of `kernels.scatter` (None, True); False sends them
        through the rough-surface steps too (the reference of tests/trace/test_compiled_tracer.py).
    count_facets : bool
        A child's ``depth`` counts facet events (each re-hit of a masked child and each facet
        event inside rough layers), as `pmmw brdf` reports scattering orders; otherwise
        (the renderer) each surface counts one interaction however many facets it took.

    Attributes
    ----------
    events : int
        Facet (or smooth-interface) events so far.
    fallbacks : int
        Facet draws whose weight was not 1 (a model's rare fallback, `roughness`).
    """

    def __init__(
        self,
        media: Media,
        frequency: float,
        faces,
        limits,
        choice,
        compiled: bool | None = None,
        count_facets: bool = False,
    ):
        self.media = media
        self.wavelength = C0 / frequency
        # which media have rough coating layers (None: none, the common case)
        layered = np.array([bool(media.rough_layers(k)) for k in range(len(media.ids))])
        self.layered = layered if layered.any() else None
        self.rough_scene = media.any_rough  # smooth scenes skip every roughness and bump step
        self.compiled = not self.rough_scene if compiled is None else bool(compiled and not self.rough_scene)
        self._faces = faces
        self._limits, self._choice = limits, Choice(int(choice[0]), int(choice[1]))
        k0 = 2.0 * np.pi * frequency / C0
        self._media, self._films, self._rough, self._rough_models, self._layer_media = kernel_tables(media, k0)
        self._rough_other = bool((self._rough.code == OTHER_CODE).any())
        self.count_facets = count_facets
        # a chain of re-hits at one point is one interaction, unless depth counts facet events
        self._rehit_depth = 0 if count_facets else -1
        self.events = self.fallbacks = 0
        self.acc = self.cut = None

    @property
    def media_table(self):
        """The media as the kernels take them (`kernel_tables`' first entry; `kernels.arrive`)."""
        return self._media

    def start(self, acc, cut):
        """Where the interactions of the next waves deposit emission: per-sample sums ``acc``
        (samples, 4) and truncation sums ``cut`` (samples, 2), float64 (`kernels.emit`,
        `kernels.survive`). Their random numbers come from the rays' keys (`pmmw.rng`)."""
        self.acc, self.cut = acc, cut

    def interact(self, wave: Wave, hit, prim, rows):
        """The interactions of rays ``rows`` of ``wave`` with the faces they hit.

        Parameters
        ----------
        wave : Wave
            Its rows ``rows`` interact; the wave's arrays are reused (reordered in place) when the
            interactions need more than one pass.
        hit : tuple
            As `kernels.arrive` fills it (pos, n_in, cos1, cur, face_med, other, leaving, code).
        prim : ndarray, shape (n,), int64
            The face each ray hit.
        rows : ndarray, shape (r,), int64
            The rows with code 2 (interacts).

        Returns
        -------
        list of Wave
            The surviving children (reflected and transmitted, off the surface).
        """
        if self.compiled:
            self.events += rows.size
            u_choose, u_roul = self._uniforms(wave.key[rows], wave.depth[rows])
            kids = Wave.empty(2 * rows.size, wave.stack.shape[1])
            count = kernels.scatter(
                rows,
                wave.arrays(),
                hit,
                self._films,
                prim,
                self._faces,
                self._media,
                self._choice,
                u_choose,
                u_roul,
                self._limits,
                self.acc,
                self.cut,
                kids.arrays(),
                kernels.NO_SETTLE,
            )
            return [kids.head(count)]
        # the interacting rays to the front of the wave, in place (its other rays are done with)
        wv = wave.head(kernels.compact(wave.arrays(), hit.code == HitCode.INTERACTS))
        pos, n_in, cur, face_med, other, leaving = (
            a[rows] for a in (hit.pos, hit.n_in, hit.cur, hit.face_med, hit.other, hit.leaving)
        )
        prim = prim[rows]
        n_mac = self._bumped(pos, wv.d, n_in, face_med)
        layered = self.layered[face_med] if self.layered is not None else None
        # the children come back terminated (`_interact`: as they leave the surface; the layer
        # walk's: here); the caller joins them once, with the rays that passed through
        if layered is None or not layered.any():
            return self._interact(wv, pos, n_in, n_mac, cur, face_med, other, leaving, prim)
        a, b = np.nonzero(~layered)[0], np.nonzero(layered)[0]
        kids = (
            self._interact(wv.take(a), pos[a], n_in[a], n_mac[a], cur[a], face_med[a], other[a], leaving[a], prim[a])
            if a.size
            else []
        )
        walked = self._walk_layers(
            wv.take(b), pos[b], n_in[b], n_mac[b], cur[b], face_med[b], other[b], leaving[b], prim[b]
        )
        return kids + [w for w in (self._terminate(part) for part in walked) if len(w)]

    def _uniforms(self, key, depth):
        """The uniforms of an interaction of the rays of keys ``key`` at depths ``depth`` that
        `kernels.scatter` reads: the branch choice (one per ray; none with ``split``) and Russian
        roulette (two per ray, the reflected child's first; none without roulette)."""
        u_choose = _NO_RANDOM
        if self._choice.strategy != kernels.STRATEGIES["split"]:
            u_choose = rng.uniforms(key, depth, Purpose.BRANCH_CHOICE)
        if not self._limits.roulette:
            return u_choose, _NO_RANDOM
        return u_choose, rng.uniforms(key, depth, Purpose.ROULETTE_REFLECTED, Purpose.ROULETTE_TRANSMITTED).ravel()

    def _models(self, face_med):
        """The roughness models of the media in ``face_med``, {medium: model}, in ascending order
        of medium (the order their facets are drawn in), smooth media left out."""
        models = {k: self.media.rough(int(k)) for k in _values(face_med)}
        return {k: mdl for k, mdl in models.items() if mdl is not None}

    def _bumped(self, pos, d, n_in, face_med):
        """Macro normals tilted by the bump maps of the faces' materials (the face normal elsewhere).

        Where the tilt exceeds the incidence (the ray would meet the back of the bump: shading
        normals cannot model that shadowing) the face normal is kept.
        """
        media = self.media
        out = n_in
        values = _values(face_med)
        for k in values:
            bump = media.bump_map(int(k))
            if bump is None:
                continue
            if values.size == 1:
                return bump.shade(pos, n_in, d)  # the usual case: every ray on one material
            g = face_med == k
            if out is n_in:
                out = n_in.copy()
            out[g] = bump.shade(pos[g], n_in[g], d[g])
        return out

    def _interact(self, wv: Wave, pos, n_geo, n_mac, cur, face_med, other, leaving, prim, rehit=0):
        """Interaction of rays with one face: emission of what it absorbs, reflected and
        transmitted children.

        ``n_geo`` is the face's geometric normal and ``n_mac`` its macro (shading) normal, a
        bump map's tilt of it, both facing the incident side. On a rough surface each ray
        first draws a microfacet normal visible from it (`pmmw.physics.roughness`, "How the
        renderer uses this") and the smooth-surface code runs about that facet; children
        masked by the microsurface re-hit the same point at once (``rehit`` counts the chain).
        Where every rough model of the scene has compiled masking (GGX, Beckmann) this is one
        pass of `kernels.scatter` (``MASKED``: GGX facets drawn there too); otherwise facets,
        `kernels.scatter` and `kernels.settle` (`_settle`) run one after the other.
        """
        self.events += len(wv)
        if self._rough_other:
            leave, back = self._scatter_settle(wv, pos, n_geo, n_mac, cur, face_med, other, leaving, prim, rehit)
        else:
            leave, back = self._scatter_masked(wv, pos, n_geo, n_mac, cur, face_med, other, leaving, prim, rehit)
        out = [leave]
        if back is not None:
            # masked children of both branches hit the same points again, as one group (with the
            # weight threshold applied first: both children of a facet may be masked, so a chain
            # could otherwise double its rays at every step)
            back, args = back[0], list(back[1:])
            keep = self._survivors(back)
            if not keep.all():
                back, args = back.head(kernels.compact(back.arrays(), keep)), [a[keep] for a in args]
            if len(back):
                out += self._interact(back, *args, rehit + 1)
        return [w for w in out if w is not None and len(w)]

    def _scatter_masked(self, wv: Wave, pos, n_geo, n_mac, cur, face_med, other, leaving, prim, rehit):
        """`_interact`'s step in one pass of `kernels.scatter` (``MASKED``). Returns the children
        that leave and, for those that come back, the arguments of their re-hit (or None).

        The uniforms are those of `_scatter_settle`'s steps, keyed by the rays (`pmmw.rng`: facets,
        branch choice, Russian roulette and masking of each child), so both give the same image
        for the same seed. The children that leave are terminated here (`survive`)."""
        nr = len(wv)
        n_mac = np.ascontiguousarray(n_mac, dtype=np.float64)
        n_fac, u1, u2 = self._draws(wv, n_mac, face_med)
        u_choose, u_roul = self._uniforms(wv.key, wv.depth)
        hit = Hit(np.ascontiguousarray(pos), n_fac, _NO_RANDOM, cur, face_med, other, leaving, _NO_CODE)
        kids = Wave.empty(2 * nr, wv.stack.shape[1])
        side = BackSide.empty(2 * nr)
        counts = np.zeros(3, np.int64)
        u_leave = _masking_uniforms(wv).ravel()
        settle = kernels.masked(
            self._rough.code == GGX_CODE,
            u1,
            u2,
            np.ascontiguousarray(n_geo),
            n_mac,
            u_leave,
            self._rough,
            rehit + 1 > MAX_REHITS,
            self.wavelength,
            self._rehit_depth,
            side,
            counts,
        )
        nl = kernels.scatter(
            np.arange(nr),
            wv.arrays(),
            hit,
            self._films,
            prim,
            self._faces,
            self._media,
            self._choice,
            u_choose,
            u_roul,
            self._limits,
            self.acc,
            self.cut,
            kids.arrays(),
            settle,
        )
        self.fallbacks += int(counts[0])
        nb = int(counts[2])
        if not nb:
            return kids.head(nl), None
        back = kids.take(np.arange(2 * nr - 1, 2 * nr - 1 - nb, -1))  # written from the end, in order
        j, cur, other, leaving, sign = (a[:nb] for a in side)
        return kids.head(nl), (
            back,
            pos[j],
            sign[:, None] * n_geo[j],
            sign[:, None] * n_mac[j],
            cur,
            face_med[j],
            other,
            leaving,
            prim[j],
        )

    def _draws(self, wv: Wave, n_mac, face_med):
        """The facet draws of `_scatter_masked`'s rays: normals (n, 3) (macro normals, or the
        facets that models without a compiled draw give, `_draw_facets`) and the GGX draws'
        uniforms u1, u2 (n,), drawn per material in `_facets`' order."""
        n_fac, u1, u2, tangent = n_mac, _NO_RANDOM, _NO_RANDOM, None
        for k, mdl in self._models(face_med).items():
            g = np.nonzero(face_med == k)[0]
            if self._rough.code[k] == GGX_CODE:  # drawn in `kernels.scatter`
                if u1 is _NO_RANDOM:
                    u1, u2 = np.zeros(len(wv)), np.zeros(len(wv))
                u1[g], u2[g] = rng.uniforms(wv.key[g], wv.depth[g], Purpose.FACET_U1, Purpose.FACET_U2).T
                continue
            if tangent is None:
                tangent, n_fac = _tangents(n_mac), n_mac.copy()
            n_fac[g] = self._draw_facets(mdl, wv, g, n_mac[g], tangent[g], self.media.temperature[k])
        return n_fac, u1, u2

    def _scatter_settle(self, wv: Wave, pos, n_geo, n_mac, cur, face_med, other, leaving, prim, rehit):
        """`_interact`'s step for scenes with a roughness model without compiled masking: facets
        (`_facets`), `kernels.scatter` about them (``AT_POINT``), `_settle` (which terminates the
        children that leave). Returns as `_scatter_masked`."""
        step = self._faces.offset[prim]
        n_fac, tangent, rough = n_mac, None, None
        if self.rough_scene:
            n_fac, tangent, rough = self._facets(wv, n_mac, face_med)
        nr = len(wv)
        cos1 = np.clip(-np.einsum("ij,ij->i", wv.d, n_fac), 0.0, 1.0)
        # the smooth code about the facets (`kernels.scatter`), its children left at the hit
        # points for the masking test
        hit = Hit(np.ascontiguousarray(pos), np.ascontiguousarray(n_fac), cos1, cur, face_med, other, leaving, _NO_CODE)
        rows = np.arange(nr)
        u_choose, u_roul = self._uniforms(wv.key, wv.depth)
        kids = Wave.empty(2 * nr, wv.stack.shape[1])
        src, branch = np.empty(2 * nr, np.int64), np.empty(2 * nr, np.int8)
        count = kernels.scatter(
            rows,
            wv.arrays(),
            hit,
            self._films,
            prim,
            self._faces,
            self._media,
            self._choice,
            u_choose,
            _NO_RANDOM,
            self._limits,
            self.acc,
            self.cut,
            kids.arrays(),
            kernels.at_point(src, branch),
        )
        return self._settle(
            kids.head(count),
            src[:count],
            branch[:count],
            pos,
            n_geo,
            n_mac,
            tangent,
            rough,
            face_med,
            prim,
            step,
            cur,
            other,
            leaving,
            rehit,
            u_roul,
            _masking_uniforms(wv),
        )

    def _facets(self, wv: Wave, n_mac, face_med):
        """Microfacet normals for the rays on rough faces (the macro normal elsewhere).

        Returns
        -------
        n_fac : ndarray, shape (n, 3)
            Facet (or macro) normals; rays whose draw found no visible facet (weight 0, only for
            degenerate input) are emitted at the surface temperature and carry on with zero power.
        tangent : ndarray, shape (n, 3) or None
            Anisotropy tangent: world X projected onto the macro plane (Y where that degenerates).
        rough : ndarray, shape (n,), bool or None
        """
        models = self._models(face_med)
        if not models:
            return n_mac, None, None
        tangent = _tangents(n_mac)
        n_fac = n_mac.copy()
        rough = np.zeros(len(wv), bool)
        for k, mdl in models.items():
            g = np.nonzero(face_med == k)[0]
            n_fac[g] = self._draw_facets(mdl, wv, g, n_mac[g], tangent[g], self.media.temperature[k])
            rough[g] = True
        return n_fac, tangent, rough

    def _draw_facets(self, model, wv: Wave, rows, n, tangent, t_surface):
        """Facet normals visible from rays ``rows`` of ``wv`` (macro normals n, facing them).

        The draw's weight multiplies the power (Jones matrix by its square root; 1 for the
        built-in models but in their rare fallback); a ray for which no facet is visible (weight
        0, degenerate input only) emits its power at ``t_surface`` and goes on with none, keeping
        the macro normal.
        """
        u = rng.uniforms(wv.key[rows], wv.depth[rows], Purpose.FACET_U1, Purpose.FACET_U2)
        m, w = model.sample_normals(n, tangent, -wv.d[rows], u[:, 0], u[:, 1])
        self.fallbacks += int(np.count_nonzero(w != 1.0))
        lost = w <= 0.0
        if lost.any():
            j = rows[lost]
            deposit(self.acc, wv.sid[j], wv.m[j], t_surface if np.ndim(t_surface) == 0 else t_surface[lost])
            wv.m[j] = 0.0
        scaled = (w > 0.0) & (w != 1.0)
        if scaled.any():
            wv.m[rows[scaled]] *= np.sqrt(w[scaled])[:, None, None]
        return np.where(w[:, None] > 0.0, m, n)

    def _settle(
        self,
        child: Wave,
        i,
        branch,
        pos,
        n_geo,
        n_mac,
        tangent,
        rough,
        face_med,
        prim,
        step,
        cur,
        other,
        leaving,
        rehit,
        u_roul,
        u_mask,
    ):
        """Send children off the surface, or back onto it.

        Returns the children that leave and, for those that do not, the arguments of their
        re-hit (`_interact` merges those of both branches into one call), or None.

        A child of a rough facet leaves with Smith's masking probability G1 about the macro
        normal of its side (0 on the wrong side); the others hit the same point again at once
        (`_interact` with ``rehit + 1``, no intersection), up to ``roughness.MAX_REHITS`` after
        which the chain's power is emitted at the surface temperature. On its way to the next
        facet a re-hitting child crosses one wavelength of its side's medium (`kernels.settle`):
        a metal-like body swallows what it transmits, a clear one lets it walk on. A child on the wrong side of the *geometric*
        face (a bump map's tilt) is mirrored through the face's plane, keeping its power.
        ``branch`` (per child) is +1 for reflected children (incident side), -1 for transmitted
        ones (far side); ``i`` their rows in the interaction's arrays; ``u_mask`` (rows, 2) the
        masking uniforms of each row's reflected and transmitted child (`_masking_uniforms`). The masking probability
        comes from each face's model; the rest is one pass of `kernels.settle`.
        """
        n = len(child)
        u, p_leave = np.zeros(n), _NO_RANDOM
        if rough is not None:
            rk = rough[i]
            u[rk] = u_mask[i[rk], (branch[rk] < 0).astype(np.int64)]
            if self._rough_other:  # models without compiled masking
                r = np.flatnonzero(self._rough.code[face_med[i]] == OTHER_CODE)
                fm, ir = face_med[i][r], i[r]
                n_x = branch[r][:, None] * n_mac[ir]
                p_leave = np.zeros(n)
                for k in _values(fm):
                    g = fm == k
                    p_leave[r[g]] = self._rough_models[int(k)].masking(n_x[g], tangent[ir[g]], child.d[r[g]])
        else:
            tangent = n_mac  # not read
        leave, back = Wave.empty(n, child.stack.shape[1]), Wave.empty(n, child.stack.shape[1])
        side = BackSide.empty(n)
        hit = Hit(pos, n_geo, _NO_RANDOM, cur, face_med, other, leaving, _NO_CODE)
        t_face = self._media.temperature[face_med]
        chain_end = ChainEnd(np.full(len(pos), rehit + 1 > MAX_REHITS), np.stack([t_face, t_face], axis=1))
        nl, nb = kernels.settle(
            child.arrays(),
            i,
            branch,
            u,
            p_leave,
            hit,
            n_mac,
            tangent,
            step,
            chain_end,
            self._media,
            self._rough,
            self.wavelength,
            self.acc,
            leave.arrays(),
            back.arrays(),
            side,
            LeaveSide.empty(n),
            True,
            self._rehit_depth,
            Fate(u_roul, self._limits, self.cut),
        )
        if not nb:
            return leave.head(nl), None
        j, cur, other, leaving, sign = (a[:nb] for a in side)
        return leave.head(nl), (
            back.head(nb),
            pos[j],
            sign[:, None] * n_geo[j],
            sign[:, None] * n_mac[j],
            cur,
            face_med[j],
            other,
            leaving,
            prim[j],
        )

    # -- rough coating layers (Optics Express 2016) ----------------------------------------------------------
    def _walk_layers(self, wv: Wave, pos, n_geo, n_mac, cur, face_med, other, leaving, prim):
        """Rays meeting a surface with rough coating layers: the Optics Express 2016 walk through them.

        The surface is a pile of interfaces at one point: interface j < L is the rough top of
        rough layer j (`RoughLayer`, with its coherent films), interface L the substrate's own
        surface (its ``coating`` films and ``roughness``). A ray on it is at an interface j, on its
        upper or lower side. Each step (`_layer_step`): draw a facet (the interface's model, or its
        macro normal), split by Fresnel / the films' multilayer about it (absorption emitted at the
        films' temperature) and mask each child, by the same kernels as any surface (each rough
        layer is a medium of the kernels' tables, `kernel_tables`; masked children stay at
        interface j on their side after one wavelength of that side's medium), and send the others across the layer they are in,
        attenuated by exp(-alpha t / cos) and emitting at the layer's temperature, to the next
        interface. A child leaving the top interface upward or the substrate's interface downward
        is a real child of the scene: reflected or transmitted as for a smooth surface. Russian
        roulette below ``render.threshold`` ends walks unbiasedly; a walk longer than
        ``_MAX_WALK`` steps is emitted at the layer's temperature. Every step keeps or splits the
        power, so an isothermal scene still reads its temperature exactly.
        """
        media = self.media
        out = []
        key = ((face_med * 4096 + cur) * 4096 + other) * 2 + leaving
        for kv in np.unique(key):
            g = np.nonzero(key == kv)[0]
            k, lv = int(face_med[g[0]]), bool(leaving[g[0]])
            pile = Pile(media, k, int(other[g[0]]) if lv else int(cur[g[0]]), self._layer_media[k])
            up = -1.0 if lv else 1.0  # side normals facing the outside
            w = wv.take(g)
            n_up, g_up, p_g, step = up * n_mac[g], up * n_geo[g], pos[g], self._faces.offset[prim[g]]
            tangent = _tangents(n_up)
            nr = len(w)
            lvl = np.full(nr, pile.n if lv else 0)
            above = np.full(nr, not lv)
            rehits = np.zeros(nr, np.int64)
            rows = np.arange(nr)  # index into the group's per-ray constants
            for _ in range(_MAX_WALK):
                n_in = np.where(above[:, None], n_up[rows], -n_up[rows])
                walk = []
                for j in np.unique(lvl):
                    j = int(j)
                    model = pile.roughness(j)
                    for a in (True, False):
                        sel = np.nonzero((lvl == j) & (above == a))[0]
                        if not sel.size:
                            continue
                        n_fac = n_in[sel]
                        if model is not None:
                            n_fac = self._draw_facets(
                                model, w, sel, n_fac, tangent[rows[sel]], pile.end_temperature(j, a)
                            )
                        exits, more = self._layer_step(
                            w.take(sel),
                            p_g[rows[sel]],
                            pile,
                            j,
                            a,
                            n_in[sel],
                            n_fac,
                            tangent[rows[sel]],
                            rehits[sel],
                            rows[sel],
                        )
                        out += [
                            self._layer_exit(child, r, exit_up, lv, k, p_g, g_up, step, pile.t_body)
                            for exit_up, child, r in exits
                        ]
                        walk += more
                walk = _merge_walk(walk)
                if walk is None:
                    break
                w, lvl, above, rehits, rows = walk
                # below the threshold the scene's termination rule; "the last object" is the
                # medium the ray is in (the body itself on its outer and inner sides)
                w.last_t = pile.end_temperatures(lvl, above)
                keep = self._survivors(w)
                if not keep.all():
                    w, lvl, above, rehits, rows = w.take(keep), lvl[keep], above[keep], rehits[keep], rows[keep]
            else:  # _MAX_WALK facet events: what is left emits where it is
                deposit(self.acc, w.sid, w.m, pile.end_temperatures(lvl, above))
        return out

    def _layer_step(self, w, pos, pile, j, a, n_in, n_fac, tangent, rehits, rows):
        """One facet event at interface j for rays on side ``a`` (True: above) at points ``pos``, by the kernels
        of every surface: `kernels.scatter` about the facets (the interface's coefficients, with
        its films; the emission of what it absorbs or a sink swallows; the branch choice), then
        `kernels.settle` without leaving the point (the interface's masking; masked children
        back at interface j on their side after one wavelength of its medium).

        Returns the real exits ``[(exit_up, wave, rows)]`` and the parts of the walk that go on,
        ``[(wave, lvl, above, rehits, rows)]``.
        """
        nr = len(w)
        self.events += nr
        cur, other = pile.index(j, a), pile.index(j, not a)
        fm = pile.index(j, False)  # the medium whose top surface interface j is
        cos1 = np.clip(-np.einsum("ij,ij->i", w.d, n_fac), 0.0, 1.0)
        hit = Hit(
            np.ascontiguousarray(pos),
            np.ascontiguousarray(n_fac),
            cos1,
            np.full(nr, cur),
            np.full(nr, fm),
            np.full(nr, other),
            np.full(nr, not a),
            _NO_CODE,
        )
        u_choose, _ = self._uniforms(w.key, w.depth)
        kids = Wave.empty(2 * nr, w.stack.shape[1])
        src, branch = np.empty(2 * nr, np.int64), np.empty(2 * nr, np.int8)
        none = np.zeros(nr, np.int64)
        count = kernels.scatter(
            np.arange(nr),
            w.arrays(),
            hit,
            self._films,
            none,
            self._faces,
            self._media,
            self._choice,
            u_choose,
            _NO_RANDOM,
            self._limits,
            self.acc,
            self.cut,
            kids.arrays(),
            kernels.at_point(src, branch),
        )
        kids, src, branch = kids.head(count), src[:count], branch[:count]
        kids.top[:] = w.top[src]  # inside the pile the media stack stays as it was (`_layer_exit`)
        model = self._rough_models[fm]
        u, p_leave = np.zeros(count), _NO_RANDOM
        if model is not None:
            u = _masking_uniforms(w)[src, (branch < 0).astype(np.int64)]
            if self._rough.code[fm] == OTHER_CODE:
                p_leave = model.masking(branch[:, None] * n_in[src], tangent[src], kids.d)
        t_end = np.array([pile.end_temperature(j, a), pile.end_temperature(j, not a)])
        chain_end = ChainEnd(rehits + 1 > MAX_REHITS, np.broadcast_to(t_end, (nr, 2)).copy())
        leave, back = Wave.empty(count, w.stack.shape[1]), Wave.empty(count, w.stack.shape[1])
        b_side, l_side = BackSide.empty(count), LeaveSide.empty(count)
        nl, nb = kernels.settle(
            kids.arrays(),
            src,
            branch,
            u,
            p_leave,
            hit,
            np.ascontiguousarray(n_in),
            np.ascontiguousarray(tangent),
            np.zeros(nr),
            chain_end,
            self._media,
            self._rough,
            self.wavelength,
            self.acc,
            leave.arrays(),
            back.arrays(),
            b_side,
            l_side,
            False,
            self._rehit_depth,
            Fate(_NO_RANDOM, self._limits, self.cut),
        )
        exits, walk = [], []
        if nb:
            i, sign = b_side.src[:nb], b_side.sign[:nb]
            walk.append((back.head(nb), np.full(nb, j), np.where(sign > 0, a, not a), rehits[i] + 1, rows[i]))
        leave = leave.head(nl)
        if not self.count_facets:
            leave.depth -= 1  # the walk is one interaction, counted where it leaves (`_layer_exit`)
        i_all, sign_all = l_side.src[:nl], l_side.sign[:nl]
        for side in (a, not a):
            sel = np.flatnonzero((sign_all > 0) == (side == a))
            if not sel.size:
                continue
            fwd, i = leave.take(sel), i_all[sel]
            if (side and j == 0) or (not side and j == pile.n):
                exits.append((side, fwd, rows[i]))
                continue
            # across the layer it is in to the neighbouring interface
            lay = pile.layers[j - 1] if side else pile.layers[j]
            kernels.cross_layer(
                fwd.arrays(),
                np.ascontiguousarray(n_in, dtype=np.float64),
                i,
                float(lay.alpha),
                float(lay.thickness),
                float(lay.temperature),
                self.acc,
            )
            walk.append(
                (
                    fwd,
                    np.full(len(fwd), j - 1 if side else j + 1),
                    np.full(len(fwd), not side),
                    np.zeros(len(fwd), np.int64),
                    rows[i],
                )
            )
        return exits, walk

    def _layer_exit(self, child, r, exit_up, leaving, k, pos, g_up, step, t_body):
        """A child leaving the layered surface: on the outside (``exit_up``) or into the body,
        with the media stack of a reflected or transmitted child and the smooth code's offset."""
        g = np.ascontiguousarray(g_up[r] if exit_up else -g_up[r])
        child.o = pos[r]
        kernels.off_surface(child.arrays(), g, np.ascontiguousarray(step[r]))
        if not self.count_facets:
            child.depth = child.depth + 1
        child.last_t = np.full(len(child), t_body)
        stack, top = child.stack.copy(), child.top.copy()
        crossed = exit_up == leaving  # left the body outward, or entered it from outside
        if crossed and not leaving:
            top += 1
            stack[np.arange(len(child)), top] = k
        elif crossed and leaving:
            top -= 1
        child.stack, child.top = stack, top
        return child

    def _terminate(self, wv: Wave):
        """Depth cut-off and weight threshold (Murakowski 2014 sec. 2.2.5, 2.2.9)."""
        keep = self._survivors(wv)
        return wv.head(kernels.compact(wv.arrays(), keep)) if not keep.all() else wv

    def _survivors(self, wv: Wave):
        """Which rays go on after the depth cut-off and the weight threshold (`kernels.survive`:
        the others' power is emitted at the last object's temperature or, by Russian roulette,
        dropped with the survivors scaled up). Returns a boolean mask."""
        n = len(wv)
        u = rng.uniforms(wv.key, wv.depth, Purpose.SURVIVAL) if self._limits.roulette else _NO_RANDOM
        keep = np.empty(n, bool)
        kernels.survivors(wv.arrays(), u, self._limits, self.acc, self.cut, keep)
        return keep


def _masking_uniforms(wv: Wave):
    """The masking uniforms of the children of the rays of ``wv``, (n, 2): the reflected child's,
    the transmitted one's (`pmmw.rng`)."""
    return rng.uniforms(wv.key, wv.depth, Purpose.MASKING_REFLECTED, Purpose.MASKING_TRANSMITTED)


def _merge_walk(parts):
    """Concatenate ``(wave, lvl, above, rehits, rows)`` tuples (None when empty)."""
    parts = [p for p in parts if len(p[0])]
    if not parts:
        return None
    return (Wave.concat([p[0] for p in parts]),) + tuple(np.concatenate([p[i] for p in parts]) for i in range(1, 5))


def _values(a):
    """The distinct values of a small integer array (`numpy.unique`), without its sort for the
    usual case of one value (a wave on one material)."""
    if a.size and a.min() == a.max():
        return a[:1]
    return np.unique(a)


def _tangents(n):
    """Unit tangents: world X projected onto the plane normal to n (world Y where n ~ X),
    `kernels.tangents`; shape (n, 3)."""
    n = np.ascontiguousarray(n, dtype=np.float64)
    out = np.empty_like(n)
    kernels.tangents(n, out)
    return out

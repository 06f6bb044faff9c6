#!/usr/bin/env python3
"""Prototype: each ray's whole path in one compiled loop that calls Embree per ray.

usage: prototype_path_loop.py SCENARIO.yaml [--spp N] [--smooth] [--split] [--pmmw] [--set K=V]
                              [--threads 1] [--repeats 2]

What it measures, on pmmw's own scene, camera and face data (`pmmw.pipeline.make_job`):

* *embreex*: pmmw's intersector (`EmbreeIntersector.intersect`, embreex's Cython loop over
  ``rtcIntersect1`` plus the float64 plane distance) on the camera rays: the "bare Embree" of
  ``pmmw bench``;
* *direct*: the same rays through ``rtcIntersect1`` called from a numba loop through ctypes
  (Embree 4, the library embreex ships; no float32 copies, no Python between rays);
* *path loop*: every camera ray's whole path in that one compiled loop, Embree called per segment:
  intersect, the float64 plane distance, the face's medium; a miss sees the sky; metal reflects;
  a dielectric face reflects with the Fresnel power coefficients of its permittivity (s and p
  carried as two weights in the plane of incidence) and emits the transmitted power at its
  temperature (the anchor's ground and runway are lossy enough that what enters does not come
  back); a rough face (GGX, Walter et al. 2007 eq. 33, 35) reflects about a drawn facet normal,
  weighted by the shadowing G1 of the outgoing direction (Smith); depth ``max_depth``.

That is not pmmw's physics (no Jones matrices, no transmitted children, no splitting, no
atmosphere, no media stack): it is the same work per segment as Mitsuba's path tracer (one path
per sample). Paths per second are comparable with Mitsuba's on the speed anchor.

* *split* (``--split``, smooth faces): pmmw's split tree in the same loop (`split_paths`): both
  children of every dielectric interaction, Jones matrices, absorption and emission in media,
  Russian roulette, max_depth; on the smooth anchor the same segments and image mean as pmmw;
* *pmmw* (``--pmmw``): pmmw's own trace of every tile in this process (one worker), between the
  loops, for a side-by-side ratio.
"""

import argparse
import ctypes
import glob
import os
import sys
import time

import numpy as np
from numba import get_num_threads, njit, prange, set_num_threads

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))


def _embree_lib():
    import embreex

    d = os.path.join(os.path.dirname(os.path.dirname(embreex.__file__)), "embreex.libs")
    return ctypes.CDLL(glob.glob(os.path.join(d, "libembree4*.so*"))[0])


_LIB = _embree_lib()
_LIB.rtcNewDevice.restype = ctypes.c_void_p
_LIB.rtcNewDevice.argtypes = [ctypes.c_char_p]
_LIB.rtcNewScene.restype = ctypes.c_void_p
_LIB.rtcNewScene.argtypes = [ctypes.c_void_p]
_LIB.rtcNewGeometry.restype = ctypes.c_void_p
_LIB.rtcNewGeometry.argtypes = [ctypes.c_void_p, ctypes.c_int]
_LIB.rtcSetSharedGeometryBuffer.argtypes = [
    ctypes.c_void_p,
    ctypes.c_int,
    ctypes.c_uint,
    ctypes.c_int,
    ctypes.c_void_p,
    ctypes.c_size_t,
    ctypes.c_size_t,
    ctypes.c_size_t,
]
for _name in ("rtcCommitGeometry", "rtcReleaseGeometry", "rtcCommitScene"):
    getattr(_LIB, _name).argtypes = [ctypes.c_void_p]
_LIB.rtcAttachGeometry.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
_LIB.rtcAttachGeometry.restype = ctypes.c_uint
# (scene, RTCRayHit*, RTCIntersectArguments* = NULL): pointers passed as 64-bit integers (x86-64)
rtc_intersect1 = _LIB.rtcIntersect1
rtc_intersect1.argtypes = [ctypes.c_uint64, ctypes.c_uint64, ctypes.c_uint64]
rtc_intersect1.restype = None

RTC_GEOMETRY_TYPE_TRIANGLE, RTC_BUFFER_TYPE_INDEX, RTC_BUFFER_TYPE_VERTEX = 0, 0, 1
RTC_FORMAT_UINT3, RTC_FORMAT_FLOAT3 = 0x5003, 0x9003
RAYHIT_FLOATS = 32  # RTCRayHit is 80 bytes (+ instPrimID in some builds): 128 bytes of room, 16-aligned
INVALID = np.uint32(0xFFFFFFFF)


class DirectScene:
    """An Embree 4 scene of a triangle soup (float32, as embreex builds it), kept alive with its
    buffers; ``ptr`` is the RTCScene for `rtc_intersect1`."""

    def __init__(self, vertices, faces):
        self.device = _LIB.rtcNewDevice(None)
        self.scene = _LIB.rtcNewScene(self.device)
        geom = _LIB.rtcNewGeometry(self.device, RTC_GEOMETRY_TYPE_TRIANGLE)
        nf = len(faces)
        self.v = np.zeros((3 * nf + 1, 3), np.float32)  # (one row of padding: Embree reads 16 bytes)
        self.v[:-1] = vertices[faces].reshape(-1, 3)
        self.i = np.arange(3 * nf, dtype=np.uint32).reshape(nf, 3)
        _LIB.rtcSetSharedGeometryBuffer(
            geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, self.v.ctypes.data, 0, 12, 3 * nf
        )
        _LIB.rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, self.i.ctypes.data, 0, 12, nf)
        _LIB.rtcCommitGeometry(geom)
        _LIB.rtcAttachGeometry(self.scene, geom)
        _LIB.rtcReleaseGeometry(geom)
        _LIB.rtcCommitScene(self.scene)
        self.ptr = int(self.scene)


def rayhit_buffers(n):
    """``n`` RTCRayHit records, each 16-byte aligned: (float32 view (n, 32), uint32 view)."""
    raw = np.zeros(n * RAYHIT_FLOATS + 4, np.float32)
    off = (-raw.ctypes.data % 16) // 4
    f = raw[off : off + n * RAYHIT_FLOATS].reshape(n, RAYHIT_FLOATS)
    return f, f.view(np.uint32)


@njit(inline="always")
def _cast(scene, rf, ru, ox, oy, oz, dx, dy, dz):
    """One rtcIntersect1; the face hit (-1: none)."""
    rf[0], rf[1], rf[2], rf[3] = ox, oy, oz, 0.0
    rf[4], rf[5], rf[6], rf[7] = dx, dy, dz, 0.0
    rf[8] = np.inf
    ru[9], ru[10], ru[11] = INVALID, 0, 0
    ru[17], ru[18] = INVALID, INVALID
    rtc_intersect1(scene, rf.ctypes.data, 0)
    return -1 if ru[18] == INVALID else np.int64(ru[17])


@njit(parallel=True)
def direct(scene, rf, ru, o, d, prim):
    """Nearest face of each ray, ``rtcIntersect1`` per ray from a compiled loop."""
    nb = rf.shape[0]
    n = o.shape[0]
    for b in prange(nb):
        for i in range(b * n // nb, (b + 1) * n // nb):
            prim[i] = _cast(scene, rf[b], ru[b], o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2])


@njit(inline="always")
def _fresnel(eps, cos_i):
    """Power reflectances (Rs, Rp) from the ambient medium into permittivity ``eps``."""
    sin2 = 1.0 - cos_i * cos_i
    ct = np.sqrt(eps - sin2 + 0j)
    rs = (cos_i - ct) / (cos_i + ct)
    rp = (eps * cos_i - ct) / (eps * cos_i + ct)
    return abs(rs) ** 2, abs(rp) ** 2


@njit(parallel=True)
def paths(
    scene,
    rf,
    ru,
    o,
    d,
    v0,
    normal,
    offset,
    face_med,
    kind,
    eps,
    temp,
    alpha_ggx,
    t_sky,
    t_ground,
    max_depth,
    seed,
    out,
    segs,
):
    """Every ray's whole path in one loop (see the module's docstring); ``out`` (n, 2): (Ts, Tp) [K];
    ``segs`` (blocks,): segments intersected per block."""
    nb = rf.shape[0]
    n = o.shape[0]
    for b in prange(nb):
        np.random.seed(seed + b)
        count = 0
        for i in range(b * n // nb, (b + 1) * n // nb):
            ox, oy, oz = o[i, 0], o[i, 1], o[i, 2]
            dx, dy, dz = d[i, 0], d[i, 1], d[i, 2]
            ws, wp, acc_s, acc_p = 1.0, 1.0, 0.0, 0.0
            for _depth in range(max_depth + 1):
                f = _cast(scene, rf[b], ru[b], ox, oy, oz, dx, dy, dz)
                count += 1
                if f < 0:  # the sky, or the ground's temperature below the horizon
                    tsk = t_sky if dz >= 0.0 else t_ground
                    acc_s += ws * tsk
                    acc_p += wp * tsk
                    break
                nx, ny, nz = normal[f, 0], normal[f, 1], normal[f, 2]
                cos = dx * nx + dy * ny + dz * nz
                t = ((v0[f, 0] - ox) * nx + (v0[f, 1] - oy) * ny + (v0[f, 2] - oz) * nz) / cos
                px, py, pz = ox + t * dx, oy + t * dy, oz + t * dz
                if cos > 0.0:  # the normal against the ray
                    nx, ny, nz, cos = -nx, -ny, -nz, -cos
                k = face_med[f]
                if _depth == max_depth:
                    acc_s += ws * temp[k]
                    acc_p += wp * temp[k]
                    break
                mx, my, mz = nx, ny, nz
                a = alpha_ggx[k]
                if a > 0.0:  # a facet normal drawn from GGX (Walter et al. 2007 eq. 35)
                    u1, u2 = np.random.random(), np.random.random()
                    tan2 = a * a * u1 / (1.0 - u1)
                    ct = 1.0 / np.sqrt(1.0 + tan2)
                    st = np.sqrt(max(0.0, 1.0 - ct * ct))
                    phi = 2.0 * np.pi * u2
                    # a frame around n
                    if abs(nx) > 0.9:
                        tx, ty, tz = ny, -nx, 0.0
                    else:
                        tx, ty, tz = 0.0, nz, -ny
                    tn = np.sqrt(tx * tx + ty * ty + tz * tz)
                    tx, ty, tz = tx / tn, ty / tn, tz / tn
                    bx, by, bz = ny * tz - nz * ty, nz * tx - nx * tz, nx * ty - ny * tx
                    c1, c2 = st * np.cos(phi), st * np.sin(phi)
                    mx, my, mz = c1 * tx + c2 * bx + ct * nx, c1 * ty + c2 * by + ct * ny, c1 * tz + c2 * bz + ct * nz
                cm = -(dx * mx + dy * my + dz * mz)
                if cm <= 0.0:
                    acc_s += ws * temp[k]
                    acc_p += wp * temp[k]
                    break
                if kind[k] == 1:  # metal
                    rs, rp = 1.0, 1.0
                else:
                    rs, rp = _fresnel(eps[k], cm)
                acc_s += ws * (1.0 - rs) * temp[k]
                acc_p += wp * (1.0 - rp) * temp[k]
                ws *= rs
                wp *= rp
                dx, dy, dz = dx + 2.0 * cm * mx, dy + 2.0 * cm * my, dz + 2.0 * cm * mz
                up = dx * nx + dy * ny + dz * nz
                if up <= 0.0:  # reflected into the surface: ends there
                    acc_s += ws * temp[k]
                    acc_p += wp * temp[k]
                    break
                if a > 0.0:  # Smith's shadowing of the outgoing direction (GGX, Walter et al. 2007 eq. 34)
                    tan2o = max(0.0, 1.0 - up * up) / (up * up)
                    g1 = 2.0 / (1.0 + np.sqrt(1.0 + a * a * tan2o))
                    acc_s += ws * (1.0 - g1) * temp[k]
                    acc_p += wp * (1.0 - g1) * temp[k]
                    ws *= g1
                    wp *= g1
                h = offset[f]
                ox, oy, oz = px + h * nx, py + h * ny, pz + h * nz
            out[i, 0] = acc_s
            out[i, 1] = acc_p
        segs[b] = count


@njit(inline="always")
def _fresnel_amp(eps_ratio, cos_i):
    """Amplitude reflection coefficients (rs, rp) at an interface of relative permittivity
    ``eps_ratio`` (far side over near side), and whether the power goes on (no total reflection)."""
    sin2 = 1.0 - cos_i * cos_i
    ct = np.sqrt(eps_ratio - sin2 + 0j)
    rs = (cos_i - ct) / (cos_i + ct)
    rp = (eps_ratio * cos_i - ct) / (eps_ratio * cos_i + ct)
    return rs, rp


@njit(parallel=True)
def split_paths(
    scene,
    rf,
    ru,
    o,
    d,
    s0,
    v0,
    normal,
    offset,
    face_med,
    kind,
    eps,
    temp,
    alpha,
    t_sky,
    t_ground,
    max_depth,
    threshold,
    seed,
    out,
    segs,
):
    """pmmw's split tree per camera ray in one loop, depth first on a small stack: every
    interaction with a dielectric face splits into the reflected ray (followed at once) and the
    transmitted one (pushed), each with its 2 x 2 complex Jones matrix, turned into the plane of
    incidence and multiplied by the Fresnel amplitudes (transmitted: the amplitude of the power
    left); in a medium, a segment attenuates by exp(-alpha t) and emits the rest at the medium's
    temperature; below ``threshold`` Russian roulette; metal reflects all; depth ``max_depth`` ends
    on the face's temperature. Smooth faces only. ``out`` (n, 2): (Ex2, Ey2) [K]."""
    nb = rf.shape[0]
    n = o.shape[0]
    size = 2 * max_depth + 4
    for b in prange(nb):
        np.random.seed(seed + b)
        count = 0
        so = np.empty((size, 3))
        sd = np.empty((size, 3))
        ss = np.empty((size, 3))
        sm = np.empty((size, 4), np.complex128)
        sdep = np.empty(size, np.int64)
        smed = np.empty(size, np.int64)
        for i in range(b * n // nb, (b + 1) * n // nb):
            ex2, ey2 = 0.0, 0.0
            top = 0
            for c in range(3):
                so[0, c], sd[0, c], ss[0, c] = o[i, c], d[i, c], s0[i, c]
            sm[0, 0], sm[0, 1], sm[0, 2], sm[0, 3] = 1.0, 0.0, 0.0, 1.0
            sdep[0], smed[0] = 0, 0
            top = 1
            while top > 0:
                top -= 1
                ox, oy, oz = so[top, 0], so[top, 1], so[top, 2]
                dx, dy, dz = sd[top, 0], sd[top, 1], sd[top, 2]
                sx, sy, sz = ss[top, 0], ss[top, 1], ss[top, 2]
                m00, m01, m10, m11 = sm[top, 0], sm[top, 1], sm[top, 2], sm[top, 3]
                depth, med = sdep[top], smed[top]
                while True:
                    f = _cast(scene, rf[b], ru[b], ox, oy, oz, dx, dy, dz)
                    count += 1
                    wx = abs(m00) ** 2 + abs(m01) ** 2
                    wy = abs(m10) ** 2 + abs(m11) ** 2
                    if f < 0:
                        if med == 0:
                            tsk = t_sky if dz >= 0.0 else t_ground
                            ex2 += wx * tsk
                            ey2 += wy * tsk
                        break
                    nx, ny, nz = normal[f, 0], normal[f, 1], normal[f, 2]
                    cos = dx * nx + dy * ny + dz * nz
                    t = ((v0[f, 0] - ox) * nx + (v0[f, 1] - oy) * ny + (v0[f, 2] - oz) * nz) / cos
                    px, py, pz = ox + t * dx, oy + t * dy, oz + t * dz
                    if cos > 0.0:
                        nx, ny, nz, cos = -nx, -ny, -nz, -cos
                    ci = -cos  # the cosine of incidence, > 0 (n against the ray)
                    k = face_med[f]
                    if med != 0:  # the segment through the medium
                        att = np.exp(-alpha[med] * max(t, 0.0))
                        ex2 += wx * (1.0 - att) * temp[med]
                        ey2 += wy * (1.0 - att) * temp[med]
                        g = np.sqrt(att)
                        m00, m01, m10, m11 = m00 * g, m01 * g, m10 * g, m11 * g
                        wx, wy = wx * att, wy * att
                        w = max(wx, wy)
                        if w < threshold:  # Russian roulette
                            if np.random.random() * threshold >= w:
                                break
                            g = np.sqrt(threshold / w)
                            m00, m01, m10, m11 = m00 * g, m01 * g, m10 * g, m11 * g
                            wx, wy = wx * threshold / w, wy * threshold / w
                    if depth >= max_depth:
                        ex2 += wx * temp[k]
                        ey2 += wy * temp[k]
                        break
                    # the plane of incidence: s' = d x n, the Jones matrix turned into (s', p')
                    qx, qy, qz = dy * nz - dz * ny, dz * nx - dx * nz, dx * ny - dy * nx
                    qn = np.sqrt(qx * qx + qy * qy + qz * qz)
                    if qn > 1e-12:
                        qx, qy, qz = qx / qn, qy / qn, qz / qn
                        pxo, pyo, pzo = dy * sz - dz * sy, dz * sx - dx * sz, dx * sy - dy * sx
                        c = sx * qx + sy * qy + sz * qz
                        sn = pxo * qx + pyo * qy + pzo * qz
                        m00, m01 = m00 * c + m01 * sn, -m00 * sn + m01 * c
                        m10, m11 = m10 * c + m11 * sn, -m10 * sn + m11 * c
                        sx, sy, sz = qx, qy, qz
                    if kind[k] == 1:  # metal
                        rs, rp = -1.0 + 0j, 1.0 + 0j
                        other = -1
                    else:
                        other = k if med == 0 else 0
                        e1 = 1.0 + 0j if med == 0 else eps[med]
                        e2 = 1.0 + 0j if other == 0 else eps[other]
                        rs, rp = _fresnel_amp(e2 / e1, ci)
                    ts = np.sqrt(max(0.0, 1.0 - abs(rs) ** 2))
                    tp = np.sqrt(max(0.0, 1.0 - abs(rp) ** 2))
                    h = offset[f]
                    if other >= 0 and (ts > 0.0 or tp > 0.0) and top < size:
                        eta = np.sqrt(e1).real / np.sqrt(e2).real
                        sin2t = eta * eta * (1.0 - ci * ci)
                        if sin2t < 1.0:
                            cost = np.sqrt(1.0 - sin2t)
                            tdx = eta * dx + (eta * ci - cost) * nx
                            tdy = eta * dy + (eta * ci - cost) * ny
                            tdz = eta * dz + (eta * ci - cost) * nz
                            so[top, 0], so[top, 1], so[top, 2] = px - h * nx, py - h * ny, pz - h * nz
                            sd[top, 0], sd[top, 1], sd[top, 2] = tdx, tdy, tdz
                            ss[top, 0], ss[top, 1], ss[top, 2] = sx, sy, sz
                            sm[top, 0], sm[top, 1] = m00 * ts, m01 * tp
                            sm[top, 2], sm[top, 3] = m10 * ts, m11 * tp
                            sdep[top], smed[top] = depth + 1, other
                            top += 1
                    m00, m01, m10, m11 = m00 * rs, m01 * rp, m10 * rs, m11 * rp
                    dx, dy, dz = dx + 2.0 * ci * nx, dy + 2.0 * ci * ny, dz + 2.0 * ci * nz
                    ox, oy, oz = px + h * nx, py + h * ny, pz + h * nz
                    depth += 1
            out[i, 0] = ex2
            out[i, 1] = ey2
        segs[b] = count


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenario")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--smooth", action="store_true", help="every face smooth")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--split", action="store_true", help="also pmmw's split tree with Jones matrices (smooth faces)")
    ap.add_argument("--pmmw", action="store_true", help="also pmmw's own trace of every tile, in this process")
    ap.add_argument("--set", action="append", default=[], help="scenario overrides, as pmmw render's")
    a = ap.parse_args()
    from pmmw.pipeline import make_job, resolve
    from pmmw.scene.camera import pixel_samples
    from pmmw.trace.intersect import EmbreeIntersector

    res = resolve(a.scenario, a.set)
    job = make_job(res, res.scenario.frequencies[0])
    cam, media = job.camera, job.media
    nk = len(media.eps)
    alpha_ggx = np.zeros(nk)
    if not a.smooth:
        for k in range(nk):
            r = media.rough(k)
            if r is not None:
                alpha_ggx[k] = float(getattr(r, "ax", 0.0))
    isect = EmbreeIntersector(job.vertices, job.faces)
    scene = DirectScene(job.vertices, job.faces)
    set_num_threads(a.threads)
    rf, ru = rayhit_buffers(get_num_threads())
    t_sky = float(job.sky.temperature)
    t_ground = float(getattr(job.sky, "ground_temperature", t_sky))
    pixels = np.arange(cam.width * cam.height, dtype=np.int64)
    chunk = max(1, (1 << 16) // a.spp)  # pixels per wave: 65536 camera rays, as pmmw's tiles trace them
    v0 = np.ascontiguousarray(job.vertices[job.faces[:, 0]])
    args = (v0, np.ascontiguousarray(job.face_normals), isect.face_offset, job.face_medium.astype(np.int64))
    args += (media.kind.astype(np.int64), media.eps.astype(complex), media.temperature.astype(float), alpha_ggx)
    print(
        f"{len(job.faces)} faces, {cam.width} x {cam.height} x {a.spp} spp, depth {job.settings.max_depth}, "
        f"rough alpha {alpha_ggx.tolist()}, {get_num_threads()} threads"
    )

    integrator = None
    if a.pmmw:
        import dataclasses

        from pmmw.trace import kernels
        from pmmw.trace.integrator import Integrator

        kernels.warm(job.settings.stack_size)
        pjob = dataclasses.replace(job, settings=dataclasses.replace(job.settings, spp=a.spp))
        integrator = Integrator(pjob, isect)
        integrator.render_tile(pjob.tiles()[0])  # kernels loaded

    def run(which):
        if which == "pmmw":
            t = time.perf_counter()
            tiles = [integrator.render_tile(tl) for tl in pjob.tiles()]
            t_in = time.perf_counter() - t
            mean = np.mean([tl.mean[..., :2].reshape(-1, 2).sum(0) for tl in tiles], axis=0) / (
                cam.width * cam.height / len(tiles)
            )
            return 0.0, t_in, sum(tl.rays for tl in tiles), mean
        t_cam = t_in = 0.0
        segs_total = 0
        total = np.zeros(2)
        for p0 in range(0, pixels.size, chunk):
            t = time.perf_counter()
            u, v, pix = pixel_samples(cam.width, pixels[p0 : p0 + chunk], a.spp, job.settings.seed, total=a.spp)
            o, d, s0, _ = cam.rays(u, v, pix, job.settings.seed)
            t_cam += time.perf_counter() - t
            t = time.perf_counter()
            if which == "embreex":
                isect.intersect(o, d)
                segs_total += len(o)
            elif which == "direct":
                prim = np.empty(len(o), np.int64)
                direct(scene.ptr, rf, ru, o, d, prim)
                segs_total += len(o)
            elif which == "split":
                out = np.empty((len(o), 2))
                segs = np.zeros(rf.shape[0], np.int64)
                split_paths(
                    scene.ptr,
                    rf,
                    ru,
                    o,
                    d,
                    s0,
                    *args[:7],
                    media.alpha.astype(float),
                    t_sky,
                    t_ground,
                    job.settings.max_depth,
                    float(job.settings.threshold),
                    1 + p0,
                    out,
                    segs,
                )
                segs_total += int(segs.sum())
                total += out.sum(axis=0)
            else:
                out = np.empty((len(o), 2))
                segs = np.zeros(rf.shape[0], np.int64)
                paths(scene.ptr, rf, ru, o, d, *args, t_sky, t_ground, job.settings.max_depth, 1 + p0, out, segs)
                segs_total += int(segs.sum())
                total += out.sum(axis=0)
            t_in += time.perf_counter() - t
        return t_cam, t_in, segs_total, total / (pixels.size * a.spp)

    # compile and check: the direct calls find the faces embreex finds
    o, d, _, _ = cam.rays(*pixel_samples(cam.width, pixels[:2000], 1, 1, total=1)[:2], np.arange(2000), 1)
    prim = np.empty(len(o), np.int64)
    direct(scene.ptr, rf, ru, o, d, prim)
    _, p_ref = isect.intersect(o, d)
    print(f"direct rtcIntersect1 agrees with embreex on {np.mean(prim == p_ref) * 100:.2f} % of 2000 camera rays")
    run("paths") if pixels.size <= chunk else None
    for rep in range(a.repeats):
        for which in ("embreex", "direct", "paths") + (("split",) if a.split else ()) + (("pmmw",) if a.pmmw else ()):
            t_cam, t_in, segs, mean = run(which)
            paths_n = pixels.size * a.spp
            extra = f", mean ({mean[0]:.2f}, {mean[1]:.2f}) K" if which in ("paths", "split", "pmmw") else ""
            print(
                f"run {rep + 1} {which:8s}: {t_in:6.2f} s for {segs / 1e6:6.2f} M segments "
                f"({t_in / segs * 1e9 * get_num_threads():5.0f} ns x thread each), {paths_n / t_in / 1e6:5.2f} M paths/s "
                f"(camera rays {t_cam:.2f} s more){extra}",
                flush=True,
            )


if __name__ == "__main__":
    main()

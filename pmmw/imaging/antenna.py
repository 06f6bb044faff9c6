"""A real antenna: the far-field beam of a circular aperture from its illumination, blockage and
spillover, and the beam's energy budget.

The aperture of radius a carries the field f(rho), rho = r / a in [0, 1], zero inside a central
blockage of diameter ratio b. Its far field is the Hankel transform (Silver 1949, ch. 6, the
circular aperture; Balanis 2016, ch. 12, circular apertures)

    F(u) = int_b^1 f(rho) J0(u rho) rho d rho,      u = k a sin(theta)                  (`pattern`)

and the power pattern |F(u) / F(0)|^2. The illuminations (`illumination`), with the edge's field
C = 10^(-T_e / 20) for an edge taper T_e [dB]:

- ``uniform``: f = 1: F(u) = J1(u) / u, the Airy pattern of Murakowski 2014 eq. 2.41.
- ``parabolic`` (parabolic on a pedestal): f = C + (1 - C)(1 - rho^2) (Balanis 2016, ch. 12, circular apertures;
  Silver 1949, ch. 6, its table of the (1 - r^2)^p illuminations, for C = 0).
- ``gaussian`` (a Gaussian feed beam truncated at the rim): f = exp(-ln(1/C) rho^2) (Goldsmith
  1998, the Gaussian illumination of an antenna).

Energy budget: the feed sends a fraction ``spillover`` of its power past the reflector, where the
beam sees ``spillover_temperature`` (the instrument, the ground, the sky); for a Gaussian feed it is
the edge taper in power, 10^(-T_e / 10) (Goldsmith 1998: the power of a Gaussian beam outside
radius a is exp(-2 a^2 / w^2), which is the edge taper). The rest forms the beam, whose energy
within angle u is (Parseval's theorem for the Hankel transform)

    EE(u) = int_0^u |F(u')|^2 u' du' / int_b^1 |f(rho)|^2 rho d rho                  (`encircled_energy`)

(for the uniform aperture Rayleigh's 1 - J0(u)^2 - J1(u)^2; Born & Wolf 1999, sec. 8.5.2, 0.838 at
the first null). The main-beam efficiency is (1 - spillover) EE(first null). The aperture
(taper) efficiency is eta_a = 2 |int f rho d rho|^2 / int |f|^2 rho d rho over the whole disc
(Balanis 2016, ch. 12, circular apertures; 1 for the uniform aperture, 0.75 for 1 - rho^2 as Silver 1949, ch. 6,
1 - b^2 with a blockage b).

Sampling: an aperture of diameter D passes angular frequencies up to D / lambda [cycles/rad], so
the image is sampled without aliasing when the pixel pitch is at most lambda / (2 D) (the Nyquist
pitch; Goodman 2005, sec. 2.4). A coarser pitch under-samples the beam and aliases.

The sensor image is T_sensor = (1 - spillover) (PSF * T) + spillover T_spill in Ex2 and Ey2 (an
unpolarized spillover: none in U and V).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from pmmw.arrays import FloatArray
from pmmw.imaging.imager import blur, kernel_extent

ILLUMINATIONS = ("uniform", "parabolic", "gaussian")
_U_STEP = 0.01  # [-] table step in u = k a sin(theta): the pattern's finest structure has period ~pi
_MAX_RADIUS_PX = 256


def edge_field(edge_taper_db: float) -> float:
    """The edge's field relative to the centre, C = 10^(-T_e / 20), of an edge taper [dB]."""
    return 10.0 ** (-edge_taper_db / 20.0)


def illumination(
    rho: np.typing.ArrayLike, kind: str = "uniform", edge_taper_db: float = 0.0, blockage: float = 0.0
) -> np.ndarray:
    """Aperture field f(rho) [-] at normalized radius ``rho`` (ndarray in [0, 1]); zero inside the
    blockage (ratio of diameters ``blockage``)."""
    rho = np.asarray(rho, dtype=float)
    c = edge_field(edge_taper_db)
    if kind == "uniform":
        f = np.ones_like(rho)
    elif kind == "parabolic":
        f = c + (1.0 - c) * (1.0 - rho**2)
    elif kind == "gaussian":
        f = np.exp(-np.log(1.0 / c) * rho**2)
    else:
        raise ValueError(f"unknown illumination {kind!r}; known: {', '.join(ILLUMINATIONS)}")
    return np.where(rho < blockage, 0.0, f)


@lru_cache(maxsize=16)
def _leggauss(n: int) -> tuple[np.ndarray, np.ndarray]:
    """numpy's Gauss-Legendre nodes and weights of order n, made once (an eigenvalue problem:
    milliseconds, and a beam's report asks for them a dozen times)."""
    x, w = np.polynomial.legendre.leggauss(n)
    x.flags.writeable = False
    w.flags.writeable = False
    return x, w


@dataclass(frozen=True)
class Aperture:
    """A circular aperture's illumination (module docstring)."""

    kind: str = "uniform"
    edge_taper_db: float = 0.0
    blockage: float = 0.0
    spillover: float = 0.0  # fraction of the feed's power that misses the reflector [-]
    spillover_temperature: float = 290.0  # [K]

    def _nodes(self, u_max: float) -> tuple[np.ndarray, np.ndarray]:
        """Gauss-Legendre nodes and weights on [blockage, 1], enough for J0(u rho) up to ``u_max``."""
        n = int(max(64, u_max / 2.0 + 64))
        x, w = _leggauss(n)
        b = self.blockage
        rho = 0.5 * (1.0 - b) * x + 0.5 * (1.0 + b)
        return rho, 0.5 * (1.0 - b) * w

    def field(self, u: np.typing.ArrayLike) -> np.ndarray:
        """F(u) [-] (module docstring) at ``u`` = k a sin(theta) (ndarray): for the uniform
        aperture without blockage its closed form J1(u) / u (1/2 at u = 0), else the quadrature."""
        from scipy import special  # imported when the imager is modelled, after the trace

        u = np.asarray(u, dtype=float)
        if self.kind == "uniform" and self.blockage == 0.0:
            out = np.full(u.shape, 0.5)
            nz = np.abs(u) > 1e-8  # J1(u) / u = 1/2 - u^2 / 16 + ...: 1/2 to 6.25e-18 below
            out[nz] = special.j1(u[nz]) / u[nz]
            return out
        flat = u.ravel()
        rho, w = self._nodes(float(flat.max(initial=0.0)))
        fw = illumination(rho, self.kind, self.edge_taper_db, self.blockage) * rho * w
        out = np.empty_like(flat)
        for s in range(0, flat.size, 4096):  # rows of (4096, nodes): bounded memory
            out[s : s + 4096] = special.j0(np.outer(flat[s : s + 4096], rho)) @ fw
        return out.reshape(u.shape)

    def power(self, u: np.typing.ArrayLike) -> np.ndarray:
        """Normalized power pattern |F(u) / F(0)|^2 [-] (1 on axis)."""
        return (self.field(u) / self.field(np.zeros(1))[0]) ** 2

    def aperture_integrals(self) -> tuple[float, float]:
        """(int f rho d rho, int |f|^2 rho d rho) over the aperture."""
        rho, w = self._nodes(0.0)
        f = illumination(rho, self.kind, self.edge_taper_db, self.blockage)
        return float(np.sum(f * rho * w)), float(np.sum(f * f * rho * w))

    def taper_efficiency(self) -> float:
        """Aperture efficiency eta_a [-] (module docstring)."""
        s1, s2 = self.aperture_integrals()
        return 2.0 * s1 * s1 / s2

    def encircled_energy(self, u: np.typing.ArrayLike) -> np.ndarray:
        """Fraction of the beam's energy within ``u`` (ndarray of increasing u >= 0) by the
        trapezoidal rule on a `_U_STEP` grid, normalized by Parseval's aperture integral."""
        u = np.atleast_1d(np.asarray(u, dtype=float))
        grid = np.arange(0.0, u.max() + 2 * _U_STEP, _U_STEP / 4.0)
        g = self.field(grid) ** 2 * grid
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(grid))])
        return np.interp(u, grid, cum) / self.aperture_integrals()[1]

    def beam_shape(self, u_max: float = 40.0) -> dict:
        """Half-power full width, first null and first sidelobe of the pattern, in u: ``hpbw_u``
        (full width, u units), ``first_null_u``, ``first_sidelobe_dB``, ``first_sidelobe_u``.

        Searched on the grid u = 0, `_U_STEP` / 4, ... below ``u_max``, first below 12 (a uniform
        aperture's first sidelobe is at u = 5.1, a tapered one's further out), then below 24, then
        below ``u_max``: the same grid points, a third of the pattern to compute for most beams."""
        for top in [t for t in (12.0, 24.0) if t < u_max] + [u_max]:
            u = np.arange(0.0, top, _U_STEP / 4.0)
            p = self.power(u)
            dp = np.diff(p)
            k = int(np.argmax(p < 0.5))
            if k == 0 or not (dp[k:] > 0).any():
                continue
            if (dp[int(np.argmax(dp[k:] > 0)) + k :] < 0).any():
                break  # the half power, the first minimum and the sidelobe's peak all inside
        k = int(np.argmax(p < 0.5))
        # half power between u[k-1] and u[k], linearly
        u_half = u[k - 1] + (0.5 - p[k - 1]) * (u[k] - u[k - 1]) / (p[k] - p[k - 1])
        dp = np.diff(p)
        i_min = int(np.argmax(dp[k:] > 0)) + k  # first minimum after the half-power point
        i_max = int(np.argmax(dp[i_min:] < 0)) + i_min  # the sidelobe's peak after it
        return {
            "hpbw_u": float(2.0 * u_half),
            "first_null_u": float(u[i_min]),
            "first_sidelobe_u": float(u[i_max]),
            "first_sidelobe_dB": float(10.0 * np.log10(p[i_max])),
        }

    def main_beam_efficiency(self) -> float:
        """(1 - spillover) x the beam's energy within its first null [-]."""
        return float((1.0 - self.spillover) * self.encircled_energy(self.beam_shape()["first_null_u"])[0])


def gaussian_feed_spillover(edge_taper_db: float) -> float:
    """Spillover [-] of a Gaussian feed beam with edge taper T_e [dB] at the rim: 10^(-T_e/10)."""
    return 10.0 ** (-edge_taper_db / 10.0)


def antenna_kernel(
    pixel_angle: float, k0: float, aperture_diameter: float, aperture: Aperture, max_radius: int = _MAX_RADIUS_PX
) -> np.ndarray:
    """Pixel-integrated PSF of ``aperture``, normalized to unit sum (as `imaging.imager.psf_kernel`
    does for the Airy pattern, with the same radius: that enclosing all but `PSF_ENERGY_TAIL` of
    the Airy pattern's energy, which tapered beams' lower sidelobes enclose better).

    Returns
    -------
    ndarray, shape (2r+1, 2r+1), float64
    """
    a = aperture_diameter / 2.0
    r, offs = kernel_extent(pixel_angle, k0, a, max_radius)
    sub = offs.size
    grid = np.arange(-r, r + 1, dtype=float)
    gx = (grid[:, None] + offs[None, :]).ravel() * pixel_angle
    tx, ty = np.meshgrid(gx, gx)
    u = k0 * a * np.sin(np.minimum(np.hypot(tx, ty), np.pi / 2))
    table_u = np.arange(0.0, u.max() + 2 * _U_STEP, _U_STEP)
    table = aperture.power(table_u)
    val = np.interp(u, table_u, table).reshape(2 * r + 1, sub, 2 * r + 1, sub).mean(axis=(1, 3))
    return val / val.sum()


def beam_report(aperture: Aperture, k0: float, aperture_diameter: float, pixel_angle: float) -> dict:
    """The beam's figures and energy budget as a report states them (angles in mrad)."""
    a = aperture_diameter / 2.0
    shape = aperture.beam_shape()
    lam = 2.0 * np.pi / k0
    nyquist = lam / (2.0 * aperture_diameter)
    spill = aperture.spillover
    in_null = float(aperture.encircled_energy(shape["first_null_u"])[0])
    return _floats(
        {
            "illumination": aperture.kind,
            **({"edge_taper_dB": aperture.edge_taper_db} if aperture.kind != "uniform" else {}),
            "blockage": aperture.blockage,
            "hpbw_mrad": 1e3 * float(np.arcsin(min(1.0, shape["hpbw_u"] / 2.0 / (k0 * a)))) * 2.0,
            "hpbw_lambda_over_D": shape["hpbw_u"] / np.pi,
            "first_null_mrad": 1e3 * float(np.arcsin(min(1.0, shape["first_null_u"] / (k0 * a)))),
            "first_sidelobe_dB": shape["first_sidelobe_dB"],
            "taper_efficiency": aperture.taper_efficiency(),
            "energy_budget": {
                "main_beam": (1.0 - spill) * in_null,
                "sidelobes": (1.0 - spill) * (1.0 - in_null),
                "spillover": spill,
                "spillover_temperature_K": aperture.spillover_temperature,
            },
            "main_beam_efficiency": (1.0 - spill) * in_null,
            "pixel_pitch_mrad": 1e3 * pixel_angle,
            "nyquist_pitch_mrad": 1e3 * nyquist,
            "pitch_over_nyquist": pixel_angle / nyquist,
            "sampling": (
                "under-sampled: the pixel pitch is coarser than lambda / 2D, the beam aliases"
                if pixel_angle > nyquist * (1 + 1e-9)
                else "Nyquist-sampled (pitch <= lambda / 2D)"
            ),
        }
    )


def _floats(d):
    """numpy scalars -> Python floats, through nested dicts (a report is YAML and JSON)."""
    return {
        k: _floats(v) if isinstance(v, dict) else float(v) if isinstance(v, np.floating) else v for k, v in d.items()
    }


# --- the field-dependent PSF: each pixel's beam seen through the projected aperture -------------

OFF_AXIS = ("fixed", "projected")
_FIELD_NODES = 7  # kernels per image axis, interpolated bilinearly between (`FieldPSF`)


def pixel_field_angles(width: int, height: int, fov: float) -> tuple[FloatArray, FloatArray]:
    """Field angle theta [rad] from the boresight and azimuth phi [rad] (from the image's +x,
    to the right, towards its top) of every pixel centre of a pinhole imager (`scene.camera`:
    square pixels, ``fov`` across the width), each of shape (height, width)."""
    half = np.tan(fov / 2.0)
    a = (2.0 * (np.arange(width) + 0.5) / width - 1.0) * half
    b = (height - 2.0 * (np.arange(height) + 0.5)) / width * half
    aa, bb = np.meshgrid(a, b)
    return np.arctan(np.hypot(aa, bb)), np.arctan2(bb, aa)


def off_axis_kernel(
    pixel_angle: float,
    k0: float,
    aperture_diameter: float,
    aperture: Aperture,
    theta: float,
    phi: float,
    max_radius: int = _MAX_RADIUS_PX,
    table: tuple[FloatArray, FloatArray] | None = None,
) -> FloatArray:
    """Pixel-integrated, unit-sum PSF of the beam that looks ``theta`` [rad] off the boresight, in
    the image direction ``phi`` [rad] (`pixel_field_angles`), on the pixels of a pinhole imager
    whose central pixel subtends ``pixel_angle`` [rad].

    The aperture seen from theta is the disc projected onto the plane normal to that direction: an
    ellipse of semi-axes a cos(theta) in the plane of theta (radial) and a across it (tangential).
    By the Fourier transform's similarity theorem (Goodman 2005, ch. 2) its pattern is the disc's
    with the radial direction cosine scaled by cos(theta): u = k a sqrt((cos(theta) s_r)^2 + s_t^2),
    so the beam widens by 1 / cos(theta) radially and keeps its width tangentially, as a scanned
    array's beam widens as 1 / cos(theta_0) (Mailloux 2005, the beamwidth of a scanned array); s_r,
    s_t [rad] are the angles from the beam's centre. Coma and the beam deviation factor of a
    displaced feed are not modelled. The pinhole's pixels shrink off axis: a pixel step is an
    angle of pixel_angle cos^2(theta) radially and pixel_angle cos(theta) tangentially (the
    gnomonic projection), so in pixels the beam spans
    1 / cos^3(theta) radially and 1 / cos(theta) tangentially what it spans at the centre. At
    theta = 0 this is `antenna_kernel`. ``table``: `power_table` reaching the largest u, when the
    caller has it (`FieldPSF`: one for all its kernels).

    Returns
    -------
    ndarray, shape (2r+1, 2r+1), float64
    """
    a = aperture_diameter / 2.0
    c = float(np.cos(theta))
    r, offs = kernel_extent(pixel_angle, k0, a, max_radius, radial_pixel_angle=pixel_angle * c**3)
    sub = offs.size
    grid = np.arange(-r, r + 1, dtype=float)
    g = (grid[:, None] + offs[None, :]).ravel()
    du, dv = np.meshgrid(g, g)  # pixel offsets: du to the right, dv down the rows
    da, db = du, -dv  # to the right and up
    s_r = (da * np.cos(phi) + db * np.sin(phi)) * pixel_angle * c**2  # radial angle [rad]
    s_t = (-da * np.sin(phi) + db * np.cos(phi)) * pixel_angle * c  # tangential angle [rad]
    u = k0 * a * np.sin(np.minimum(np.hypot(c * s_r, s_t), np.pi / 2))
    table_u, power = table if table is not None else power_table(aperture, float(u.max()))
    val = np.interp(u, table_u, power).reshape(2 * r + 1, sub, 2 * r + 1, sub).mean(axis=(1, 3))
    return val / val.sum()


def power_table(aperture: Aperture, u_max: float) -> tuple[FloatArray, FloatArray]:
    """(u, |F(u) / F(0)|^2) on the `_U_STEP` grid from 0 past ``u_max``, for `np.interp`."""
    table_u = np.arange(0.0, u_max + 2 * _U_STEP, _U_STEP)
    return table_u, aperture.power(table_u)


class FieldPSF:
    """A field-dependent blur: each sensor pixel reads the scene through its own beam
    (`off_axis_kernel` at that pixel's field angle). The kernels are computed on a grid of
    ``nodes`` x ``nodes`` pixels spanning the image (corners included) and interpolated bilinearly
    between them: sensor(x) = sum_j w_j(x) (K_j * T)(x), with hat weights w_j that sum to 1, so a
    uniform scene stays uniform. The error of the interpolation is second order in the kernels'
    change over a node spacing. The kernels reach at most the image's larger side (beyond it the
    mirrored borders would only repeat the image), so that a small image's many kernels stay small."""

    def __init__(
        self,
        pixel_angle: float,
        k0: float,
        aperture_diameter: float,
        aperture: Aperture,
        width: int,
        height: int,
        fov: float,
        nodes: int = _FIELD_NODES,
    ) -> None:
        theta, phi = pixel_field_angles(width, height, fov)
        self.shape = (height, width)
        self.max_field_angle = float(theta.max())  # [rad], at the corners
        self.max_radius = min(_MAX_RADIUS_PX, max(width, height))
        self.rows = np.unique(np.round(np.linspace(0, height - 1, min(nodes, height))).astype(int))
        self.cols = np.unique(np.round(np.linspace(0, width - 1, min(nodes, width))).astype(int))
        table = power_table(aperture, k0 * aperture_diameter / 2.0)  # u = k a sin(.) <= k a
        # the beam is mirrored about the image's centre lines: where node (i, W-1-j) exists, the
        # kernel of node (i, j) is its kernel flipped left-right, and likewise (H-1-i, j)'s flipped
        # up-down. Along an odd side the nodes lie symmetrically (np.round's ties mirror too), so a
        # quarter of the kernels are computed; along an even side ties round to the even integer
        # and some nodes have no mirror image (20 px: 0 3 6 10 13 16 19; 10 has no 9), and those
        # are computed
        self.kernels: dict[tuple[int, int], np.ndarray] = {}
        for i in self.rows:
            for j in self.cols:
                mi, mj = height - 1 - i, width - 1 - j
                if (i, mj) in self.kernels:
                    self.kernels[(i, j)] = self.kernels[(i, mj)][:, ::-1].copy()
                elif (mi, j) in self.kernels:
                    self.kernels[(i, j)] = self.kernels[(mi, j)][::-1, :].copy()
                else:
                    self.kernels[(i, j)] = off_axis_kernel(
                        pixel_angle, k0, aperture_diameter, aperture, theta[i, j], phi[i, j], self.max_radius, table
                    )

    @staticmethod
    def _hats(nodes: FloatArray, n: int) -> FloatArray:
        """Hat weights (len(nodes), n) of positions 0..n-1 on ``nodes`` (piecewise-linear, sum 1)."""
        x = np.arange(n, dtype=float)
        if len(nodes) == 1:
            return np.ones((1, n))
        return np.stack([np.interp(x, nodes, np.eye(len(nodes))[k]) for k in range(len(nodes))])

    def blur_all(self, images: dict[str, FloatArray]) -> dict[str, FloatArray]:
        """The sensor images (H, W) float64 of the ideal ones (a dict of name -> (H, W)), each kernel
        applied to every image in turn (its spectrum is computed once: `imaging.imager.blur`)."""
        imgs = {c: np.asarray(v, float) for c, v in images.items()}
        wr, wc = self._hats(self.rows, self.shape[0]), self._hats(self.cols, self.shape[1])
        out = {c: np.zeros(self.shape) for c in imgs}
        for (i, j), kern in self.kernels.items():
            w = np.outer(wr[list(self.rows).index(i)], wc[list(self.cols).index(j)])
            for c, v in imgs.items():
                out[c] += w * blur(v, kern)
        return out

    def kernel_at(self, row: float, col: float) -> FloatArray:
        """The beam of the pixel at (``row``, ``col``) (fractional positions allowed): the node
        kernels blended with the weights `blur_all` gives that pixel, each padded to the largest
        one (unit sum). A region's detection uses the kernel at its centre (`pipeline.region_stats`)."""
        eye_r, eye_c = np.eye(len(self.rows)), np.eye(len(self.cols))
        wr = [float(np.interp(row, self.rows, eye_r[k])) if len(self.rows) > 1 else 1.0 for k in range(len(self.rows))]
        wc = [float(np.interp(col, self.cols, eye_c[k])) if len(self.cols) > 1 else 1.0 for k in range(len(self.cols))]
        r = max(k.shape[0] for k in self.kernels.values()) // 2
        out = np.zeros((2 * r + 1, 2 * r + 1))
        for (i, j), kern in self.kernels.items():
            w = wr[list(self.rows).index(i)] * wc[list(self.cols).index(j)]
            if w > 0.0:
                q = kern.shape[0] // 2
                out[r - q : r + q + 1, r - q : r + q + 1] += w * kern
        return out / out.sum()

    def blur(self, img: FloatArray) -> FloatArray:
        """The sensor image (H, W) float64 of the ideal image ``img`` (H, W)."""
        return self.blur_all({"": img})[""]

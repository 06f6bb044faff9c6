"""The imager model of Murakowski 2014 sec. 2.2.8: Airy-disk PSF and additive Gaussian noise.

The PSF is eq. 2.41, I(th) = (2 J1(k a sin th) / (k a sin th))^2 with a the aperture radius,
integrated over each pixel's angular footprint (supersampled so that pixels wider than the Airy
core are integrated, not point-sampled), truncated where the enclosed energy is within
`PSF_ENERGY_TAIL` of 1, and normalized to unit sum so that flux is conserved. It is applied to
every channel by FFT convolution, with the image mirrored at its borders so that edges do not
darken. The same angular pitch is assumed for every pixel (small field of view, as Murakowski 2014).

Noise: independent zero-mean Gaussian of the stated sigma [K] on Ex2, Ey2, U and V; I and Q are
then formed from the noisy Ex2 and Ey2 (so I = Ex2 + Ey2 still holds in the sensor image).
"""

from __future__ import annotations

import hashlib
import threading
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from pmmw.arrays import FloatArray

if TYPE_CHECKING:
    from pmmw.imaging.antenna import FieldPSF
    from pmmw.imaging.receiver import Receiver

PSF_ENERGY_TAIL = 2e-3  # fraction of the Airy energy allowed outside the kernel
_MAX_RADIUS_PX = 256


def airy(theta: FloatArray, k0: float, radius: float) -> FloatArray:
    """Airy intensity pattern (eq. 2.41), 1 on axis.

    Parameters
    ----------
    theta : ndarray, float64
        Off-axis angle [rad].
    k0 : float
        Wavenumber [1/m].
    radius : float
        Aperture radius a [m].
    """
    from scipy.special import j1  # imported when the imager is modelled, after the trace

    x = k0 * radius * np.sin(np.abs(theta))
    out = np.ones_like(x)
    nz = x > 1e-12
    out[nz] = (2.0 * j1(x[nz]) / x[nz]) ** 2
    return out


def _airy_encircled_energy(x):
    """Fraction of Airy energy within k a sin(th) = x (Rayleigh: 1 - J0^2 - J1^2)."""
    from scipy.special import j0, j1

    return 1.0 - j0(x) ** 2 - j1(x) ** 2


def psf_kernel(pixel_angle: float, k0: float, aperture_diameter: float, max_radius: int = _MAX_RADIUS_PX) -> FloatArray:
    """Pixel-integrated Airy kernel, normalized to unit sum (computed once per set of arguments:
    a render asks for it when sizing adaptive sampling and again for the imager model; each caller
    gets its own copy).

    Parameters
    ----------
    pixel_angle : float
        Angular pitch of the pixels [rad].
    k0 : float
        Wavenumber [1/m].
    aperture_diameter : float
        [m].

    Returns
    -------
    ndarray, shape (2r+1, 2r+1), float64
    """
    return _psf_kernel(float(pixel_angle), float(k0), float(aperture_diameter), int(max_radius)).copy()


@lru_cache(maxsize=1)
def _tail_x() -> float:
    """x = k a sin(theta) enclosing all but `PSF_ENERGY_TAIL` of the Airy pattern's energy; the
    tail of the encircled energy goes as 2 / (pi x), so it lies below 1.5 times 2 / (pi tail)."""
    x_max = 2.0 / (np.pi * PSF_ENERGY_TAIL)
    xs = np.linspace(1.0, x_max * 1.5, 20000)
    ok = _airy_encircled_energy(xs) >= 1.0 - PSF_ENERGY_TAIL
    return float(xs[np.argmax(ok)]) if ok.any() else x_max


def kernel_extent(
    pixel_angle: float, k0: float, radius: float, max_radius: int, radial_pixel_angle: float | None = None
) -> tuple[int, FloatArray]:
    """(r, offsets) of a pixel-integrated beam kernel of an aperture of ``radius`` [m]: r pixels
    each side, enough for all but `PSF_ENERGY_TAIL` of the Airy pattern's energy (at most
    ``max_radius``; ``radial_pixel_angle`` [rad]: a pixel step measured in the beam's own angle
    where it is not ``pixel_angle``, off axis the radial step pitch cos^2(theta) times the
    projected aperture's cos(theta)), and the sub-sample offsets within a
    pixel: at least 5 across the Airy core (its first zero, 1.22 lambda / D), 3 to 15, odd."""
    theta_max = np.arcsin(min(1.0, _tail_x() / (k0 * radius)))
    r = int(np.ceil(theta_max / (pixel_angle if radial_pixel_angle is None else radial_pixel_angle)))
    r = max(1, min(r, max_radius))
    core = 3.8317 / (k0 * radius)
    sub = int(np.clip(np.ceil(5.0 * pixel_angle / core), 3, 15)) | 1
    return r, (np.arange(sub) + 0.5) / sub - 0.5


@lru_cache(maxsize=8)
def _psf_kernel(pixel_angle: float, k0: float, aperture_diameter: float, max_radius: int) -> FloatArray:
    a = aperture_diameter / 2.0
    r, offs = kernel_extent(pixel_angle, k0, a, max_radius)
    sub = offs.size
    # one quadrant (pixels 0..r from the centre), mirrored: the pattern depends on |theta| alone,
    # and the sub-samples of pixel -i are those of pixel i mirrored; within the quadrant the
    # sub-samples' pattern is symmetric about its diagonal (hypot(x, y) = hypot(y, x)): half of it
    grid = np.arange(0, r + 1, dtype=float)
    gx = (grid[:, None] + offs[None, :]).ravel() * pixel_angle
    iu, ju = np.triu_indices(gx.size)
    fine = np.empty((gx.size, gx.size))
    fine[iu, ju] = airy(np.hypot(gx[iu], gx[ju]), k0, a)
    fine[ju, iu] = fine[iu, ju]
    quadrant = fine.reshape(r + 1, sub, r + 1, sub).mean(axis=(1, 3))
    half = np.concatenate([quadrant[:0:-1], quadrant], axis=0)
    val = np.concatenate([half[:, :0:-1], half], axis=1)
    return val / val.sum()


def error_footprint(kernel: FloatArray) -> float:
    """1 / sqrt(sum psf^2) of a unit-sum kernel: how much larger than the blurred error the
    per-pixel errors may be (>= 1).

    Blurring independent per-pixel errors sigma_k gives sqrt(sum_k psf_k^2 sigma_k^2), at most
    max(sigma) sqrt(sum psf^2): pixels whose error is at most target / sqrt(sum psf^2) leave a
    blurred error at most target. For a locally uniform sigma this is exact, not a bound.
    """
    return float(1.0 / np.sqrt(np.sum(np.square(kernel))))


def fftconvolve(in1: FloatArray, in2: FloatArray, mode: str = "same") -> FloatArray:
    """``scipy.signal.fftconvolve(in1, in2, mode="same")`` of two real arrays, by the same
    operations with `scipy.fft` alone (scipy 1.17's ``_freq_domain_conv``: real FFTs of the
    next fast lengths, axes of length 1 by broadcasting, the centre cut out), so the numbers are
    the same to the bit; the kernel's transform is kept for the next call (`_spectrum`). Importing ``scipy.signal`` loads ``scipy.stats`` too, about 0.5 s on a
    2-core machine, more than the imager model itself takes. Returns float64 of in1's shape."""
    from scipy import fft as sp_fft

    if mode != "same":
        raise ValueError(f"only mode='same' is implemented, got {mode!r}")
    in1 = np.asarray(in1, dtype=np.float64)
    in2 = np.asarray(in2, dtype=np.float64)
    if in1.ndim != in2.ndim:
        raise ValueError("in1 and in2 should have the same dimensionality")
    s1, s2 = in1.shape, in2.shape
    axes = [a for a in range(in1.ndim) if s1[a] != 1 and s2[a] != 1]
    shape = [s1[i] + s2[i] - 1 if i in axes else max(s1[i], s2[i]) for i in range(in1.ndim)]
    if axes:
        fshape = [sp_fft.next_fast_len(shape[a], True) for a in axes]
        sp1 = sp_fft.rfftn(in1, fshape, axes=axes)
        ret = sp_fft.irfftn(sp1 * _spectrum(in2, fshape, axes), fshape, axes=axes)
        ret = ret[tuple(slice(n) for n in shape)]
    else:
        ret = in1 * in2
    start = [(c - n) // 2 for c, n in zip(ret.shape, s1)]
    return ret[tuple(slice(b, b + n) for b, n in zip(start, s1))].copy()


#: The last kernels' spectra (`_spectrum`): a render blurs four channels and each region's
#: footprint with one PSF, and the regions' adjoint with the flipped one.
_SPECTRA: dict = {}
_SPECTRA_LOCK = threading.Lock()


def _spectrum(kernel, fshape, axes):
    """``scipy.fft.rfftn(kernel, fshape, axes)``, kept for the next image blurred with the same
    kernel (known by its bytes): a third of each convolution's transforms."""
    from scipy import fft as sp_fft

    key = (hashlib.blake2b(kernel.tobytes(), digest_size=16).digest(), kernel.shape, tuple(fshape), tuple(axes))
    with _SPECTRA_LOCK:  # renders in threads (the API) share it
        if key not in _SPECTRA:
            while len(_SPECTRA) >= 2:
                del _SPECTRA[next(iter(_SPECTRA))]
            _SPECTRA[key] = sp_fft.rfftn(kernel, fshape, axes=axes)
        return _SPECTRA[key]


def mirror_symmetric(kernel: FloatArray) -> bool:
    """Is ``kernel`` (square, odd side) unchanged by flipping either axis, to 1e-12 of its largest
    value (the Airy and antenna kernels: a circular aperture's beam)?"""
    k = np.asarray(kernel)
    if k.ndim != 2 or k.shape[0] != k.shape[1] or k.shape[0] % 2 != 1:
        return False
    tol = 1e-12 * float(np.max(np.abs(k))) if k.size else 0.0
    return bool(np.max(np.abs(k - k[::-1, :])) <= tol and np.max(np.abs(k - k[:, ::-1])) <= tol)


def _folded(k: FloatArray, n: int, axis: int) -> FloatArray:
    """The kernel's half (centre on) along ``axis``, wrapped onto the 2n-periodic grid of the
    mirrored image: entry m sums the taps at offsets congruent to m modulo 2n, m = 0..n."""
    r = k.shape[axis] // 2
    at = np.arange(-r, r + 1) % (2 * n)
    keep = at <= n
    moved = np.moveaxis(k, axis, 0)
    out = np.zeros((n + 1,) + moved.shape[1:])
    np.add.at(out, at[keep], moved[keep])
    return np.moveaxis(out, 0, axis)


#: The last kernels' DCT multipliers (`_dct_multiplier`): (kernel, h, w, multiplier or None).
_MULTIPLIERS: list = []


def _dct_multiplier(kernel: FloatArray, h: int, w: int) -> FloatArray | None:
    """The multiplier of a mirror-symmetric kernel in the orthonormal DCT-II basis of an (h, w)
    image (`blur`): its 2h x 2w periodic wrap's Fourier transform, real and even, which is the
    DCT-I of the wrap's first quadrant (Martucci 1994: symmetric convolution); None for a kernel that is not
    mirror-symmetric. Kept for the next image blurred with the same kernel (compared entry by
    entry: cheaper than hashing it), as a render blurs four channels and each region with one.
    Returns (h, w) float64 or None."""
    from scipy import fft as sp_fft

    with _SPECTRA_LOCK:  # renders in threads (the API) share it
        for k, hh, ww, mult in _MULTIPLIERS:
            if (hh, ww) == (h, w) and k.shape == kernel.shape and np.array_equal(k, kernel):
                return mult
        mult = None
        if mirror_symmetric(kernel):
            mult = sp_fft.dctn(_folded(_folded(kernel, h, 0), w, 1), type=1)[:h, :w]
        _MULTIPLIERS.append((np.array(kernel, dtype=np.float64), h, w, mult))
        del _MULTIPLIERS[:-2]
        return mult


def blur(img: FloatArray, kernel: FloatArray) -> FloatArray:
    """Convolve an image (H, W) with a kernel, mirroring the borders. Returns (H, W) float64.

    The image mirrored about its edges (numpy's ``symmetric`` padding, repeated for a kernel wider
    than the image) is periodic, of period 2H x 2W; a mirror-symmetric kernel (`mirror_symmetric`)
    keeps that symmetry, so the blur is diagonal in the DCT-II basis of the H x W image: a
    transform of the image itself, not of the image padded by the kernel's radius (Martucci 1994:
    the landing's 500 x 500 image and 513 x 513 Airy kernel, 500 x 500 transforms against
    1536 x 1536, nine times faster). Other kernels: the padded image's FFT convolution. The two
    agree to round-off (tests/imaging/test_imager_convolution.py).
    """
    h, w = img.shape
    mult = _dct_multiplier(np.asarray(kernel, dtype=np.float64), h, w)
    if mult is not None:
        from scipy import fft as sp_fft

        spectrum = sp_fft.dctn(np.asarray(img, dtype=np.float64), type=2, norm="ortho")
        spectrum *= mult
        return sp_fft.idctn(spectrum, type=2, norm="ortho")
    r = kernel.shape[0] // 2
    padded = np.pad(img, r, mode="symmetric")  # numpy repeats the reflection for large r
    out = fftconvolve(padded, kernel, mode="same")
    return out[r : r + h, r : r + w]


def self_adjoint(kernel: FloatArray | None, shape: tuple[int, int]) -> bool:
    """Is `blur` with ``kernel`` on (H, W) images its own adjoint (`blur_adjoint`), as it is for a
    mirror-symmetric kernel? False without a kernel."""
    return kernel is not None and _dct_multiplier(np.asarray(kernel, dtype=np.float64), *shape) is not None


def blur_adjoint(weights: FloatArray, kernel: FloatArray) -> np.ndarray:
    """The transpose of `blur`: for a linear functional sum(weights * blur(img)) of the sensor
    image, the per-pixel weights it puts on the ideal image. (H, W) -> (H, W) float64.

    Exact, borders included: the adjoint of the mirrored padding folds the padded margin back
    onto the pixels it was copied from; the kernel is flipped for the adjoint of convolution. A
    mirror-symmetric kernel's blur is its own adjoint (diagonal in the orthonormal DCT-II basis
    with a real multiplier: `blur`), so it is `blur` itself.
    """
    if self_adjoint(kernel, weights.shape):
        return blur(weights, kernel)
    r = kernel.shape[0] // 2
    h, w = weights.shape
    index = np.pad(np.arange(h * w).reshape(h, w), r, mode="symmetric")
    g = np.zeros(index.shape)
    g[r : r + h, r : r + w] = weights
    g = fftconvolve(g, kernel[::-1, ::-1], mode="same")
    return np.bincount(index.ravel(), weights=g.ravel(), minlength=h * w).reshape(h, w)


def apply_imager(
    ideal: dict,
    *,
    pixel_angle: float,
    k0: float,
    aperture_diameter: float,
    noise: float,
    seed: int,
    kernel: FloatArray | None = None,
    spillover: float = 0.0,
    spillover_temperature: float = 0.0,
    receiver: Receiver | None = None,
    noise_maps: dict | None = None,
    field_psf: FieldPSF | None = None,
) -> dict[str, FloatArray]:
    """The sensor image from the ideal one.

    Parameters
    ----------
    ideal : dict of str -> ndarray (H, W)
        Must hold ``Ex2, Ey2, U, V`` [K].
    pixel_angle, k0, aperture_diameter : float
        See `psf_kernel`; no blur when ``aperture_diameter`` is 0.
    noise : float
        1-sigma Gaussian noise [K] per polarization channel; none when 0.
    seed : int
    kernel : ndarray, optional
        The PSF (`psf_kernel` of these arguments, or an antenna's `imaging.antenna.antenna_kernel`),
        when the caller has it already.
    spillover, spillover_temperature : float
        Fraction [-] of the beam that sees ``spillover_temperature`` [K] instead of the scene
        (`imaging.antenna`): Ex2 and Ey2 become (1 - s) PSF * T + s T_spill, U and V (1 - s) PSF * T.
    receiver : imaging.receiver.Receiver, optional
        Noise per pixel from its own antenna temperature by the radiometer equation, instead of
        ``noise`` (which must then be 0).
    noise_maps : dict, optional
        Filled with the per-pixel 1-sigma noise [K] of every channel (``I, Q, U, V, Ex2, Ey2``)
        when a ``receiver`` is given.
    field_psf : imaging.antenna.FieldPSF, optional
        A field-dependent blur (each pixel's own beam) instead of ``kernel``'s one PSF.

    Returns
    -------
    dict of str -> ndarray (H, W)
        ``I, Q, U, V, Ex2, Ey2`` of the sensor.
    """
    base = {c: np.asarray(ideal[c], float) for c in ("Ex2", "Ey2", "U", "V")}
    if aperture_diameter > 0.0 and field_psf is not None:
        base = field_psf.blur_all(base)
    elif aperture_diameter > 0.0:
        kern = kernel if kernel is not None else psf_kernel(pixel_angle, k0, aperture_diameter)
        base = {c: blur(v, kern) for c, v in base.items()}
    if spillover > 0.0:
        base = {
            c: (1.0 - spillover) * v + (spillover * spillover_temperature if c in ("Ex2", "Ey2") else 0.0)
            for c, v in base.items()
        }
    if receiver is not None:
        maps = receiver.sigma_maps(base)
        if noise_maps is not None:
            noise_maps.update(maps)
        rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence([seed, 0x5EED])))
        base = {c: v + rng.normal(0.0, maps[c]) for c, v in base.items()}
    elif noise > 0.0:
        rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence([seed, 0x5EED])))
        base = {c: v + rng.normal(0.0, noise, v.shape) for c, v in base.items()}
    ex2, ey2 = base["Ex2"], base["Ey2"]
    return {"I": ex2 + ey2, "Q": ex2 - ey2, "U": base["U"], "V": base["V"], "Ex2": ex2, "Ey2": ey2}

"""Independent radar-cross-section references for testing the physical-optics (PO) solver.

Nothing here imports ``pmmw_cli``: the values come from NumPy, SciPy and miepython only, so a
PO solver that agrees with them has been checked against code it shares nothing with.

Conventions
-----------
* RCS ``sigma = lim_{r->inf} 4 pi r^2 |E_s|^2 / |E_i|^2`` [m^2].
* Angles in degrees in the mesh frame: ``theta`` from +z, ``phi`` from +x toward +y, with
  ``r_hat = (sin t cos p, sin t sin p, cos t)``, ``theta_hat = (cos t cos p, cos t sin p, -sin t)``,
  ``phi_hat = (-sin p, cos p, 0)``.
* ``incidence = (theta_i, phi_i)`` is the direction the wave comes FROM; it propagates along
  ``-r_hat(theta_i, phi_i)``, and backscatter is observed at ``(theta_i, phi_i)``.
* ``polarization="theta"`` puts the incident E along ``theta_hat(theta_i, phi_i)``, ``"phi"`` along
  ``phi_hat(theta_i, phi_i)``. ``rcs_theta``/``rcs_phi`` use the components of E_s along
  ``theta_hat``/``phi_hat`` at the observation direction.
* Time convention exp(-i omega t): a lossy permittivity has ``Im eps >= 0``.
  miepython takes ``m = n - i kappa`` (kappa >= 0), so it is passed ``m = conj(sqrt(eps))``;
  it conjugates any ``Im m > 0`` itself, and its ``coefficients`` equal Bohren & Huffman's
  a_n, b_n for ``n + i kappa`` (checked in tests/physical_optics/test_po_refs.py).

References (full entries belong in docs/references.md):
* Bohren & Huffman 1983, *Absorption and Scattering of Light by Small Particles*, ch. 3-4:
  amplitude matrix (eq. 3.12), a_n, b_n in Riccati-Bessel form (eq. 4.53), S1, S2 (eq. 4.74).
* Ruck, Barrick, Stuart & Krichbaum 1970, *Radar Cross Section Handbook*, vol. 1, ch. 3 (sphere).
* Knott, Shaeffer & Tuley 2004, *Radar Cross Section*, 2nd ed., the table of simple-shape RCS
  formulas (flat plate, dihedral, trihedral).
"""

import miepython
import numpy as np
from scipy.optimize import brentq
from scipy.special import spherical_jn, spherical_yn

__all__ = [
    "SINC2_FIRST_SIDELOBE_DB",
    "dihedral_peak_rcs",
    "mie_coefficients",
    "plate_first_null_deg",
    "plate_first_sidelobe_deg",
    "plate_rcs",
    "sphere_amplitudes",
    "sphere_backscatter_rcs",
    "sphere_bistatic_rcs",
    "trihedral_peak_rcs",
]

# Orders beyond Wiscombe's x + 4.05 x^(1/3) + 2; cheap, and keeps truncation far below test tolerances.
_EXTRA_ORDERS = 8
# Below this sin(scattering angle) the scattering plane is undefined (exact forward/back direction).
_SIN_PLANE_EPS = 1e-12

# First side lobe of sinc^2(u): u_1 is the root of tan u = u in (pi, 3 pi / 2).
_U_SIDELOBE = brentq(lambda u: np.sin(u) - u * np.cos(u), np.pi + 0.1, 1.5 * np.pi - 1e-9)
SINC2_FIRST_SIDELOBE_DB = float(20.0 * np.log10(abs(np.sin(_U_SIDELOBE) / _U_SIDELOBE)))  # -13.26 dB


def _n_orders(x):
    return int(x + 4.05 * x ** (1.0 / 3.0) + 2.0) + _EXTRA_ORDERS


def mie_coefficients(x, eps):
    """Mie coefficients a_n, b_n in Bohren & Huffman's exp(-i omega t) convention.

    Parameters
    ----------
    x : float
        Size parameter k a [-].
    eps : complex or None
        Relative permittivity [-] (Im eps >= 0 for loss); None for a perfect conductor.

    Returns
    -------
    a, b : ndarray, shape (N,), complex128
        Orders n = 1..N.
    """
    if eps is None:
        # Bohren & Huffman 1983 eqs. 4.53 with m -> infinity:
        # a_n = psi_n'(x) / xi_n'(x), b_n = psi_n(x) / xi_n(x), psi_n = x j_n, xi_n = x h_n^(1).
        n = np.arange(1, _n_orders(x) + 1)
        j, dj = spherical_jn(n, x), spherical_jn(n, x, derivative=True)
        h = j + 1j * spherical_yn(n, x)
        dh = dj + 1j * spherical_yn(n, x, derivative=True)
        a = (j + x * dj) / (h + x * dh)
        b = j / h
        return a, b
    eps = complex(eps)
    if eps.imag < 0:
        raise ValueError(f"eps={eps}: Im eps must be >= 0 (exp(-i omega t), lossy or lossless)")
    m = np.conj(np.sqrt(eps))
    if m.real <= 0:
        # miepython reads Re m <= 0 as a perfect conductor
        raise ValueError(f"eps={eps}: Re sqrt(eps) must be > 0; use eps=None for a perfect conductor")
    a, b = miepython.coefficients(m, x, n_pole=_n_orders(x))
    return np.asarray(a, dtype=np.complex128), np.asarray(b, dtype=np.complex128)


def sphere_amplitudes(x, eps, mu):
    """Amplitude functions S1, S2 (Bohren & Huffman 1983 eq. 4.74), exp(-i omega t).

    Parameters
    ----------
    x : float
        Size parameter k a [-].
    eps : complex or None
        Relative permittivity [-]; None for a perfect conductor.
    mu : array_like, shape (...), float
        Cosine of the scattering angle [-].

    Returns
    -------
    S1, S2 : ndarray, shape (...), complex128
        ``E_perp_s = S1 E_perp_i``, ``E_par_s = S2 E_par_i`` (times exp(ikr) / (-ikr)).
    """
    a, b = mie_coefficients(x, eps)
    mu = np.asarray(mu, dtype=np.float64)
    s1 = np.zeros(mu.shape, dtype=np.complex128)
    s2 = np.zeros(mu.shape, dtype=np.complex128)
    # Bohren & Huffman 1983 ch. 4: upward recurrence for pi_n, tau_n
    pi_nm1 = np.zeros_like(mu)
    pi_n = np.ones_like(mu)
    for n in range(1, len(a) + 1):
        tau_n = n * mu * pi_n - (n + 1) * pi_nm1
        c = (2 * n + 1) / (n * (n + 1))
        s1 += c * (a[n - 1] * pi_n + b[n - 1] * tau_n)
        s2 += c * (a[n - 1] * tau_n + b[n - 1] * pi_n)
        pi_nm1, pi_n = pi_n, ((2 * n + 1) * mu * pi_n - (n + 1) * pi_nm1) / n
    return s1, s2


def _frame(theta_deg, phi_deg):
    t, p = np.deg2rad(theta_deg), np.deg2rad(phi_deg)
    st, ct, sp, cp = np.sin(t), np.cos(t), np.sin(p), np.cos(p)
    r_hat = np.stack([st * cp, st * sp, ct], axis=-1)
    theta_hat = np.stack([ct * cp, ct * sp, -st], axis=-1)
    phi_hat = np.stack([-sp, cp, np.zeros_like(p)], axis=-1)
    return r_hat, theta_hat, phi_hat


def _dot(u, v):
    return np.sum(u * v, axis=-1)


def sphere_bistatic_rcs(
    radius, wavelength, eps, theta_obs_deg, phi_obs_deg, incidence=(0.0, 0.0), polarization="theta"
):
    """Exact (Mie) bistatic RCS of a sphere centred at the origin.

    Parameters
    ----------
    radius : float
        Sphere radius [m].
    wavelength : float
        Free-space wavelength [m].
    eps : complex or None
        Relative permittivity [-], Im eps >= 0 for loss (exp(-i omega t)); None: perfect conductor.
    theta_obs_deg, phi_obs_deg : array_like, broadcastable shapes, float
        Observation direction [deg].
    incidence : (float, float)
        (theta_i, phi_i) [deg], the direction the wave comes from.
    polarization : {"theta", "phi"}
        Incident E along theta_hat or phi_hat at the incidence direction.

    Returns
    -------
    rcs_theta, rcs_phi : ndarray, broadcast shape of the observation angles, float64
        RCS of the theta_hat and phi_hat components of the scattered field [m^2].
    """
    if polarization not in ("theta", "phi"):
        raise ValueError(f"polarization={polarization!r}: expected 'theta' or 'phi'")
    k = 2.0 * np.pi / wavelength
    r_i, theta_hat_i, phi_hat_i = _frame(*incidence)
    k_hat = -r_i
    e_i = theta_hat_i if polarization == "theta" else phi_hat_i

    theta_obs, phi_obs = np.broadcast_arrays(
        np.asarray(theta_obs_deg, dtype=np.float64), np.asarray(phi_obs_deg, dtype=np.float64)
    )
    r_s, theta_hat_s, phi_hat_s = _frame(theta_obs, phi_obs)

    # Scattering plane spanned by k_hat and r_s (Bohren & Huffman 1983 ch. 3):
    # e_par_i is r_s's part normal to k_hat, e_perp_i = e_par_i x k_hat = e_perp_s,
    # e_par_s = theta_hat of r_s in the frame whose polar axis is k_hat.
    mu = np.clip(r_s @ k_hat, -1.0, 1.0)
    v = r_s - mu[..., None] * k_hat
    sin_scat = np.linalg.norm(v, axis=-1)
    # exactly forward/back S1 = +-S2, so any plane gives the same field; take the one containing E_i
    degenerate = sin_scat < _SIN_PLANE_EPS
    e_par_i = np.where(degenerate[..., None], e_i, v / np.where(degenerate, 1.0, sin_scat)[..., None])
    e_perp_i = np.cross(e_par_i, k_hat)
    e_par_s = mu[..., None] * e_par_i - sin_scat[..., None] * k_hat
    e_perp_s = e_perp_i

    s1, s2 = sphere_amplitudes(k * radius, eps, mu)
    e_s = (s2 * _dot(e_par_i, e_i))[..., None] * e_par_s + (s1 * _dot(e_perp_i, e_i))[..., None] * e_perp_s
    # |E_s|^2 r^2 / |E_i|^2 = |S|^2 / k^2  (Bohren & Huffman 1983 eq. 3.12)
    rcs_theta = 4.0 * np.pi / k**2 * np.abs(_dot(e_s, theta_hat_s)) ** 2
    rcs_phi = 4.0 * np.pi / k**2 * np.abs(_dot(e_s, phi_hat_s)) ** 2
    return rcs_theta, rcs_phi


def sphere_backscatter_rcs(radius, wavelength, eps):
    """Exact (Mie) monostatic RCS of a sphere [m^2].

    ``sigma / (pi a^2) = |sum_n (2n+1) (-1)^n (a_n - b_n)|^2 / x^2`` (from S1(180 deg), eq. 4.74),
    computed directly from the coefficients, not through the bistatic geometry.

    Parameters
    ----------
    radius : float
        Sphere radius [m].
    wavelength : float
        Free-space wavelength [m].
    eps : complex or None
        Relative permittivity [-]; None for a perfect conductor.
    """
    x = 2.0 * np.pi * radius / wavelength
    a, b = mie_coefficients(x, eps)
    n = np.arange(1, len(a) + 1)
    return float(np.pi * radius**2 * np.abs(np.sum((2 * n + 1) * (-1.0) ** n * (a - b))) ** 2 / x**2)


def plate_rcs(a, b, wavelength, theta_deg):
    """PO monostatic RCS of a perfectly conducting a x b plate, rotated in the x-z plane.

    The plate lies in z = 0, centred at the origin, side ``a`` along x and ``b`` along y; the
    radar sits at (theta, phi = 0). Knott 2004, simple-shape table:

        sigma = 4 pi (a b / lambda)^2 cos^2(theta) [sin(u) / u]^2,  u = k a sin(theta),

    where u is half the round-trip phase 2 k sin(theta) x across the half-width a/2 (sin(u)/u,
    not numpy's sin(pi u)/(pi u)). PO gives the same value for both polarizations in this plane.

    Parameters
    ----------
    a, b : float
        Plate sides along x and y [m].
    wavelength : float
        Free-space wavelength [m].
    theta_deg : array_like, shape (...), float
        Monostatic angle from the plate normal +z [deg].

    Returns
    -------
    ndarray, shape (...), float64
        RCS [m^2].
    """
    theta = np.deg2rad(np.asarray(theta_deg, dtype=np.float64))
    u = 2.0 * np.pi / wavelength * a * np.sin(theta)
    return 4.0 * np.pi * (a * b / wavelength) ** 2 * np.cos(theta) ** 2 * np.sinc(u / np.pi) ** 2


def plate_first_null_deg(a, wavelength):
    """Angle of the first null of :func:`plate_rcs`, k a sin(theta) = pi [deg].

    Raises ValueError when a <= lambda / 2 (no null before grazing).
    """
    s = wavelength / (2.0 * a)
    if s >= 1.0:
        raise ValueError(f"a={a} m <= lambda/2={wavelength / 2} m: the pattern has no null")
    return float(np.rad2deg(np.arcsin(s)))


def plate_first_sidelobe_deg(a, wavelength):
    """Angle of the first sidelobe peak of sinc^2(k a sin theta), k a sin(theta) = 4.4934 [deg].

    The sinc^2 factor is SINC2_FIRST_SIDELOBE_DB there; :func:`plate_rcs` relative to broadside
    is that plus 20 log10(cos theta), and its true maximum is shifted slightly by the cos^2 factor.
    """
    s = _U_SIDELOBE * wavelength / (2.0 * np.pi * a)
    if s >= 1.0:
        raise ValueError(f"a={a} m too small: the first sidelobe lies beyond grazing")
    return float(np.rad2deg(np.arcsin(s)))


def trihedral_peak_rcs(a, wavelength):
    """Peak RCS of a triangular trihedral corner reflector [m^2], Knott 2004 simple-shape table.

    ``sigma = 4 pi a^4 / (3 lambda^2)``, along the symmetry axis (1, 1, 1)/sqrt(3) of a corner
    whose three right-isosceles faces share the corner; ``a`` [m] is the length of each of the
    three edges that meet at the corner (the outer edges are a sqrt 2). It equals
    4 pi A^2 / lambda^2 for the triple-bounce aperture A = a^2 / sqrt(3) (a hexagon, 2/3 of the
    projected opening).
    """
    return 4.0 * np.pi * a**4 / (3.0 * wavelength**2)


def dihedral_peak_rcs(a, b, wavelength):
    """Peak RCS of a 90-degree dihedral of two a x b plates [m^2], Knott 2004 simple-shape table.

    ``sigma = 8 pi a^2 b^2 / lambda^2``: ``a`` [m] is the width of each face measured from the fold
    perpendicular to it, ``b`` [m] the length of the fold. The peak is along the bisector, in the
    plane perpendicular to the fold, where the double-bounce aperture is sqrt(2) a b.
    """
    return 8.0 * np.pi * a**2 * b**2 / wavelength**2

"""Polarization convention of pmmw: Jones matrices per ray, Stokes per pixel.

This is the one place the convention is stated; every other module refers to it.

Frames
------
* The imager basis is (x, y, k_view): x = image right, y = image up, k_view = viewing direction.
  The wave that reaches the detector propagates along ``k = -k_view``, and (x, y, k) is
  right-handed.
* Rays are traced backwards from the imager, along the trace direction ``d``; the physical wave on
  that segment propagates along ``k = -d``.
* Each pixel measures Ex and Ey in its own basis perpendicular to its ray: x projected onto the
  plane perpendicular to ``d`` and normalized, and y = k x x. On the optical axis this is the
  imager's (x, y); off axis it keeps the detector's response unitary, so a pixel at the edge of a
  wide field of view still reads T from an isothermal blackbody (projecting the field onto the
  on-axis x and y, as eq. 2.11b reads literally, would lose a factor up to cos^2 of the off-axis
  angle).
* Each traced segment carries a real orthonormal basis (s, p) perpendicular to ``d`` with
  ``p = k x s`` (Murakowski 2014 eq. 2.23b). At an interface with normal n (pointing back into the
  incident medium), ``s = n x k / |n x k|``: the same s for the incident, reflected and
  transmitted waves, so the interface acts as ``diag(chi_s, chi_p)`` (eq. 2.39, 2.40).
* Fresnel amplitudes follow PHYSICS.md: r_s is the E-field ratio, r_p the H-field ratio
  (eq. 2.24b); with p = k x s a perfect conductor at normal incidence returns E_r = -E_i.
* Rays leaving the scene see the sky in the basis of the global Z axis (sec. 2.2.5):
  ``h = Z x k / |Z x k|`` (horizontal polarization) and ``v = k x h`` (vertical polarization).

Jones bookkeeping
-----------------
A ray carries ``M`` (n, 2, 2) complex128 that maps field components in its current (s, p) basis to
the detector's (Ex, Ey) (eq. 2.11b). Changing to a new basis (s', p') multiplies on the right by
``B = [[s'.s, p'.s], [s'.p, p'.p]]`` (eq. 2.35), and an interaction by ``diag(chi_s, chi_p)``.

Stokes from an emission event
-----------------------------
An incoherent emitter whose two basis components carry brightness temperatures ``Ta`` (first
column of N) and ``Tb`` (second column), seen through ``N = M diag(d_a, d_b)``, adds (eq. 2.14,
2.15 with A^2 = Ta, B^2 = Tb):

    Ex2 += |N00|^2 Ta + |N01|^2 Tb        Ey2 += |N10|^2 Ta + |N11|^2 Tb
    U   += 2 Re(N00 N10* Ta + N01 N11* Tb)    V += 2 Im(N00 N10* Ta + N01 N11* Tb)

and I = Ex2 + Ey2, Q = Ex2 - Ey2 (eq. 2.12). V > 0 is left-circular seen from the detector.
All four are Rayleigh-Jeans brightness temperatures [K] and add linearly over rays (eq. 2.16).
"""

from __future__ import annotations

import numpy as np

from pmmw.arrays import ComplexArray, FloatArray


def basis_change(s_old: FloatArray, p_old: FloatArray, s_new: FloatArray, p_new: FloatArray) -> FloatArray:
    """Matrix taking components in (s_new, p_new) to components in (s_old, p_old).

    Parameters
    ----------
    s_old, p_old, s_new, p_new : ndarray, shape (n, 3), float64
        Real unit basis vectors.

    Returns
    -------
    ndarray, shape (n, 2, 2), float64
        ``B`` with ``M_new = M_old @ B`` (Murakowski 2014 eq. 2.35).
    """
    b = np.empty((s_old.shape[0], 2, 2))
    b[:, 0, 0] = np.einsum("ij,ij->i", s_new, s_old)
    b[:, 0, 1] = np.einsum("ij,ij->i", p_new, s_old)
    b[:, 1, 0] = np.einsum("ij,ij->i", s_new, p_old)
    b[:, 1, 1] = np.einsum("ij,ij->i", p_new, p_old)
    return b


def rebase(m: ComplexArray, s_old: FloatArray, p_old: FloatArray, s_new: FloatArray, p_new: FloatArray) -> ComplexArray:
    """``M @ basis_change(s_old, p_old, s_new, p_new)``: a Jones matrix re-expressed in a new
    local basis (Murakowski 2014 eq. 2.35), written out per element (3 x faster than a batched matmul
    of 2 x 2 matrices).

    Parameters
    ----------
    m : ndarray, shape (n, 2, 2), complex128
    s_old, p_old, s_new, p_new : ndarray, shape (n, 3), float64

    Returns
    -------
    ndarray, shape (n, 2, 2), complex128
    """
    b = basis_change(s_old, p_old, s_new, p_new)
    out = np.empty_like(m)
    m0, m1 = m[:, :, 0], m[:, :, 1]
    out[:, :, 0] = m0 * b[:, 0, 0][:, None] + m1 * b[:, 1, 0][:, None]
    out[:, :, 1] = m0 * b[:, 0, 1][:, None] + m1 * b[:, 1, 1][:, None]
    return out


def stokes_terms(n_mat: ComplexArray, ta: FloatArray, tb: FloatArray) -> FloatArray:
    """Stokes contributions of incoherent emission seen through ``N``.

    Parameters
    ----------
    n_mat : ndarray, shape (n, 2, 2), complex128
        ``N = M diag(d_a, d_b)``: the ray's Jones matrix times the emission amplitudes.
    ta, tb : ndarray, shape (n,), float64
        Brightness temperatures of the two basis components [K].

    Returns
    -------
    ndarray, shape (n, 4), float64
        Contributions to (Ex2, Ey2, U, V) [K], see the module docstring.
    """
    n00, n01, n10, n11 = n_mat[:, 0, 0], n_mat[:, 0, 1], n_mat[:, 1, 0], n_mat[:, 1, 1]
    cross = n00 * np.conj(n10) * ta + n01 * np.conj(n11) * tb
    out = np.empty((n_mat.shape[0], 4))
    out[:, 0] = (n00.real**2 + n00.imag**2) * ta + (n01.real**2 + n01.imag**2) * tb
    out[:, 1] = (n10.real**2 + n10.imag**2) * ta + (n11.real**2 + n11.imag**2) * tb
    out[:, 2] = 2.0 * cross.real
    out[:, 3] = 2.0 * cross.imag
    return out


def row_power(m: ComplexArray) -> FloatArray:
    """Largest fraction of detector power a branch can still carry, max over Ex and Ey rows.

    Parameters
    ----------
    m : ndarray, shape (n, 2, 2), complex128

    Returns
    -------
    ndarray, shape (n,), float64
        ``max(|M00|^2 + |M01|^2, |M10|^2 + |M11|^2)``; the weight compared with ``render.threshold``.
    """
    p = m.real**2 + m.imag**2
    return np.maximum(p[:, 0, 0] + p[:, 0, 1], p[:, 1, 0] + p[:, 1, 1])


def stokes_images(acc: FloatArray) -> dict[str, FloatArray]:
    """Per-pixel (Ex2, Ey2, U, V) -> the six output channels.

    Parameters
    ----------
    acc : ndarray, shape (..., 4), float64

    Returns
    -------
    dict of str -> ndarray, shape (...)
        ``I, Q, U, V, Ex2, Ey2`` [K] (eq. 2.12).
    """
    ex2, ey2, u, v = (acc[..., i] for i in range(4))
    return {"I": ex2 + ey2, "Q": ex2 - ey2, "U": u, "V": v, "Ex2": ex2, "Ey2": ey2}

"""The receiver behind the antenna: per-pixel noise from the hardware by the radiometer equation.

A radiometer that integrates a pre-detection bandwidth B [Hz] for a time tau [s] measures its
antenna temperature T_A with a 1-sigma error (Ulaby & Long 2014, the radiometer chapter's
sensitivity of total-power and Dicke receivers with gain fluctuations; Skou & Le Vine 2006)

    total power:  dT = (T_A + T_rec) sqrt(1 / (B tau) + (dG/G)^2)                 (`radiometer_sigma`)
    Dicke:        dT = sqrt( (2 (T_A + T_rec)^2 + 2 (T_ref + T_rec)^2) / (B tau)
                             + (dG/G)^2 (T_A - T_ref)^2 )

with T_rec the receiver noise temperature and dG/G the receiver's gain fluctuation over the
integration. A balanced Dicke receiver (T_ref = T_A) gives dT = 2 (T_A + T_rec) / sqrt(B tau),
twice the total-power receiver's without gain fluctuation, and no gain-fluctuation term at all.
So the noise of a pixel depends on what it looks at: a pixel seeing a 300 K body is noisier than
one seeing a 40 K sky. A noise figure F [dB] gives T_rec = T0 (10^(F/10) - 1) with T0 = 290 K
(the IEEE reference temperature; Pozar 2012, ch. 10, noise figure).

The time each pixel is integrated is ``integration_time``, or, for a scanned imager making
``frame_rate`` images per second with ``receivers`` receivers each scanning ``pixels_per_receiver``
pixels, the dwell tau = 1 / (frame_rate pixels_per_receiver).

Channels: Ex2 and Ey2 are the antenna temperatures of the x- and y-polarized receivers (a 300 K
blackbody reads 300 K in each: docs/PHYSICS.md), each with its own noise; U and V, the correlation
of the two, take the noise of a receiver at the mean of the two antenna temperatures (an
approximation of the correlator's); I and Q, the sum and difference of the noisy Ex2 and Ey2,
carry sqrt(sigma_x^2 + sigma_y^2). The NETD pmmw states is `radiometer_sigma` at a stated scene
temperature (`NETD_SCENE_K`, and the image's own range).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from pmmw.arrays import FloatArray

T0_NOISE_FIGURE = 290.0  # [K] the reference temperature of a noise figure (IEEE; Pozar 2012, ch. 10, noise figure)
NETD_SCENE_K = 300.0  # [K] the scene temperature the NETD is stated at (a room-temperature scene)

MODES = ("total_power", "dicke")


def noise_temperature(noise_figure_db: float) -> float:
    """Receiver noise temperature [K] of a noise figure [dB]: T0 (10^(F/10) - 1), T0 = 290 K."""
    return T0_NOISE_FIGURE * (10.0 ** (noise_figure_db / 10.0) - 1.0)


def dwell_time(frame_rate: float, pixels_per_receiver: int) -> float:
    """Integration time per pixel [s] of a scanned imager: 1 / (frame_rate [Hz] x pixels each
    receiver scans)."""
    return 1.0 / (frame_rate * pixels_per_receiver)


def radiometer_sigma(
    t_a: npt.ArrayLike,
    t_rec: float,
    bandwidth: float,
    tau: float,
    mode: str = "total_power",
    gain_fluctuation: float = 0.0,
    t_ref: float | None = None,
) -> float | FloatArray:
    """1-sigma noise [K] of a radiometer reading antenna temperature ``t_a`` (module docstring).

    Parameters
    ----------
    t_a : float or ndarray, float64
        Antenna temperature [K] (per pixel).
    t_rec : float
        Receiver noise temperature [K].
    bandwidth : float
        Pre-detection bandwidth B [Hz].
    tau : float
        Integration time per pixel [s].
    mode : {"total_power", "dicke"}
    gain_fluctuation : float
        dG/G [-] over the integration time.
    t_ref : float, optional
        Dicke reference load [K]; None: balanced (T_ref = T_A).

    Returns
    -------
    float or ndarray like ``t_a`` [K]
    """
    t_a = np.asarray(t_a, dtype=float)
    bt = bandwidth * tau
    if mode == "total_power":
        out = (t_a + t_rec) * np.sqrt(1.0 / bt + gain_fluctuation**2)
    elif mode == "dicke":
        ref = t_a if t_ref is None else t_ref
        out = np.sqrt(
            (2.0 * (t_a + t_rec) ** 2 + 2.0 * (ref + t_rec) ** 2) / bt + gain_fluctuation**2 * (t_a - ref) ** 2
        )
    else:
        raise ValueError(f"unknown receiver mode {mode!r}; known: {', '.join(MODES)}")
    return out if out.ndim else float(out)


@dataclass(frozen=True)
class Receiver:
    """A receiver as the noise model takes it (SI: [K], [Hz], [s])."""

    t_rec: float
    bandwidth: float
    tau: float
    mode: str = "total_power"
    gain_fluctuation: float = 0.0
    t_ref: float | None = None

    def sigma(self, t_a: npt.ArrayLike) -> float | FloatArray:
        """`radiometer_sigma` of this receiver at antenna temperature ``t_a`` [K]."""
        return radiometer_sigma(t_a, self.t_rec, self.bandwidth, self.tau, self.mode, self.gain_fluctuation, self.t_ref)

    def netd(self, t_scene: float = NETD_SCENE_K) -> float:
        """Noise-equivalent temperature difference [K] at scene temperature ``t_scene`` [K]."""
        return float(self.sigma(t_scene))

    def sigma_maps(self, base: dict) -> dict:
        """Per-pixel noise [K] of every channel from the noiseless sensor image ``base`` (``Ex2,
        Ey2, U, V`` (H, W) [K], after the antenna): Ex2 and Ey2 from their own antenna
        temperature, U and V from their mean, I and Q the quadrature sum of Ex2's and Ey2's."""
        sx, sy = self.sigma(base["Ex2"]), self.sigma(base["Ey2"])
        suv = self.sigma(0.5 * (base["Ex2"] + base["Ey2"]))
        both = np.hypot(sx, sy)
        return {"Ex2": sx, "Ey2": sy, "U": suv, "V": suv, "I": both, "Q": both}

    def summary(self, noise_maps: dict | None = None) -> dict:
        """What a report states: the receiver, its NETD at `NETD_SCENE_K` and, given the image's
        per-pixel noise (`sigma_maps`), the range of that of Ex2 and Ey2."""
        out = {
            "noise_temperature_K": float(self.t_rec),
            "bandwidth_GHz": self.bandwidth / 1e9,
            "integration_time_s": self.tau,
            "mode": self.mode,
            "gain_fluctuation": self.gain_fluctuation,
            **({"reference_temperature_K": self.t_ref} if self.t_ref is not None else {}),
            "bandwidth_time_product": float(self.bandwidth * self.tau),
            "netd_K": self.netd(),
            "netd_scene_K": NETD_SCENE_K,
        }
        if noise_maps:
            s = np.concatenate([np.ravel(noise_maps["Ex2"]), np.ravel(noise_maps["Ey2"])])
            out["pixel_noise_K"] = {"min": float(s.min()), "mean": float(s.mean()), "max": float(s.max())}
        return out

"""One detection criterion for every "visible", "detectable" and "invisible" pmmw states.

A target is **detectable** when the signal-to-noise ratio of a matched filter for its signal in
the sensor image is at least `ROSE_SNR` = 5: Rose's criterion (Rose 1948, who found that an
observer needs an SNR of about 5 over the target's area to see it with certainty; Burgess 1999
shows the matched filter, the ideal observer of a known signal in white Gaussian noise, is what
that SNR measures). The signal is what the target changes in the sensor image: the image with
the target minus the image without it, both after the PSF and before the noise, s (H, W) [K]. With
independent Gaussian noise of sigma [K] per pixel, the matched filter's SNR is

    SNR = sqrt(sum_k s_k^2) / sigma                                  (`matched_filter_snr`)

(Barrett & Myers 2004, sec. 13.2: d' of the ideal observer). For a target of uniform contrast dT
(ideal image, before the PSF) over a region M that changes nothing else, s = dT (psf * 1_M), the
target's blurred footprint, so

    SNR = |dT| sqrt(sum_k (psf * 1_M)_k^2) / sigma                   (`region_snr`)

which is Rose's contrast times the square root of the area in pixels where there is no blur, and
falls as the blur spreads a small target over a spot much larger than itself. A render's report
uses `region_snr` with the contrast of a pair of regions ("target - background": the background's
mean standing for the image without the target); `docs/validation.md` uses `matched_filter_snr`
of two renders, with and without the target, whose control (the target replaced by what is
around it) must fail the criterion.

The noise sigma is that of the channel as `imaging.imager.apply_imager` makes it: the imager's
per-pixel noise for Ex2, Ey2, U and V (each detected with its own noise), sqrt(2) times it for I
and Q (the sum and difference of the noisy Ex2 and Ey2). Without imager noise the SNR is infinite
and the criterion says nothing (None). With a receiver (`imaging.receiver`) each pixel has its own
noise; the matched filter then whitens it (`effective_sigma`).

The criterion as a probability: a matched filter thresholded for a false-alarm probability Pfa per
target-sized test detects with probability Pd = Q(Q^-1(Pfa) - SNR) (Kay 1998, eq. 4.14;
`probability_of_detection`); SNR 5 is Pd = 0.97 at Pfa = 1e-3 per test.
"""

from __future__ import annotations

import numpy as np

#: Rose's threshold: a matched-filter SNR of at least 5 is a detection (Rose 1948; Burgess 1999).
ROSE_SNR = 5.0

CRITERION = (
    "detectable when the matched-filter signal-to-noise ratio over the target's blurred "
    f"footprint is at least {ROSE_SNR:g} (Rose 1948)"
)

#: Channels whose noise is the imager's per-pixel sigma (`apply_imager` adds it to each); I and Q,
#: the sum and difference of the noisy Ex2 and Ey2, carry sqrt(2) sigma.
POLARIZATION_CHANNELS = ("Ex2", "Ey2", "U", "V")


def channel_sigma(noise: float, channel: str) -> float:
    """The per-pixel noise [K] of ``channel`` for an imager of per-polarization noise ``noise``
    [K]: ``noise`` for Ex2, Ey2, U, V; ``sqrt(2) noise`` for I and Q."""
    return float(noise) if channel in POLARIZATION_CHANNELS else float(noise) * np.sqrt(2.0)


def footprint(mask: np.typing.ArrayLike, kernel: np.ndarray | None = None) -> np.ndarray:
    """The blurred footprint of a region: ``psf * 1_M``, (H, W) float64, from a boolean (H, W)
    ``mask`` and the imager's unit-sum PSF ``kernel`` (None: no blur)."""
    m = np.asarray(mask, dtype=float)
    if kernel is None:
        return m
    from pmmw.imaging.imager import blur

    return blur(m, kernel)


def footprint_norm(mask: np.typing.ArrayLike, kernel: np.ndarray | None = None) -> float:
    """sqrt(sum_k (psf * 1_M)_k^2) [-]: sqrt(N) for an unblurred region of N pixels, less where
    the blur spreads it (`norm_of` its `footprint`)."""
    return norm_of(footprint(mask, kernel))


def norm_of(footprint: np.typing.ArrayLike) -> float:
    """sqrt(sum_k f_k^2) [-] of a footprint already made (`footprint`)."""
    return float(np.sqrt(np.sum(np.square(np.asarray(footprint, dtype=float)))))


def matched_filter_snr(signal: np.typing.ArrayLike, sigma: float) -> float | None:
    """SNR of the matched filter for ``signal`` (H, W) [K] in white noise ``sigma`` [K] per pixel:
    sqrt(sum signal^2) / sigma; None when ``sigma`` is 0 (no noise: nothing to say)."""
    if not sigma > 0.0:
        return None
    return float(np.sqrt(np.sum(np.square(np.asarray(signal, dtype=float)))) / sigma)


def replicate_snr(signal_a: np.typing.ArrayLike, signal_b: np.typing.ArrayLike, sigma: float) -> float | None:
    """`matched_filter_snr` of a signal known only through two independent Monte Carlo estimates
    ``signal_a``, ``signal_b`` (H, W) [K] (the two replicates of a render pair, `trace.integrator.
    TileResult.replicate_diff`): sqrt(max(sum a b, 0)) / sigma. The product of independent
    estimates is an unbiased estimate of sum s^2, where the square of one estimate adds its
    whole Monte Carlo variance, summed over every pixel of the image, to the signal's energy."""
    if not sigma > 0.0:
        return None
    energy = float(np.sum(np.asarray(signal_a, dtype=float) * np.asarray(signal_b, dtype=float)))
    return float(np.sqrt(max(energy, 0.0)) / sigma)


def region_snr(
    contrast: float,
    mask: np.typing.ArrayLike,
    kernel: np.ndarray | None,
    sigma: float,
    norm: float | None = None,
) -> float | None:
    """SNR of a target of uniform ``contrast`` [K] (ideal image) over the region ``mask``, seen
    through the PSF ``kernel`` in noise ``sigma`` [K] per pixel; None without noise. ``norm``:
    the region's `footprint_norm`, when the caller has it already (a report uses it for every
    channel)."""
    if not sigma > 0.0:
        return None
    return abs(float(contrast)) * (footprint_norm(mask, kernel) if norm is None else float(norm)) / sigma


def effective_sigma(mask: np.typing.ArrayLike, kernel: np.ndarray | None, sigma_map: np.typing.ArrayLike) -> float:
    """The one noise sigma [K] of a matched filter for the target ``mask`` blurred by ``kernel`` in
    independent noise whose sigma differs from pixel to pixel (``sigma_map`` (H, W) [K], a
    receiver's: `imaging.receiver`). The prewhitened matched filter's SNR is
    sqrt(sum_k s_k^2 / sigma_k^2) (Barrett & Myers 2004, sec. 13.2), which equals
    `region_snr`'s ``|dT| norm / sigma_eff`` with sigma_eff = norm / sqrt(sum_k (fp_k / sigma_k)^2),
    fp the blurred footprint and norm its `footprint_norm`; uniform noise gives sigma_eff = sigma."""
    fp = footprint(mask, kernel)
    norm = np.sqrt(np.sum(fp * fp))
    return float(norm / np.sqrt(np.sum(np.square(fp / np.asarray(sigma_map, dtype=float)))))


def probability_of_detection(snr: np.typing.ArrayLike, pfa: float) -> float | np.ndarray:
    """Probability of detection [-] of a matched filter at matched-filter SNR ``snr`` (float or
    ndarray) and false-alarm probability ``pfa`` [-] per test, for a known signal in white
    Gaussian noise: Pd = Q(Q^-1(Pfa) - SNR), Q the Gaussian tail probability (Kay 1998, eq. 4.14).
    Rose's SNR of 5 gives Pd = 0.5 at Pfa = Q(5) = 2.9e-7 and Pd = 0.97 at Pfa = 1e-3."""
    out = _tail(_tail_inverse(pfa) - np.asarray(snr, dtype=float))
    return out if np.ndim(out) else float(out)


def required_snr(pd: float, pfa: float) -> float:
    """The matched-filter SNR that gives detection probability ``pd`` at false-alarm probability
    ``pfa`` (the inverse of `probability_of_detection`): Q^-1(Pfa) - Q^-1(Pd)."""
    return float(_tail_inverse(pfa) - _tail_inverse(pd))


def _tail(x):
    """Q(x), the standard Gaussian's tail probability P(X > x) [-]: ndtr(-x), as
    ``scipy.stats.norm.sf`` computes it (``scipy.special`` alone: importing ``scipy.stats`` takes
    about 0.5 s of a render's report on a 2-core machine)."""
    from scipy.special import ndtr

    return ndtr(-np.asarray(x, dtype=float))


def _tail_inverse(q):
    """Q^-1(q), the x with P(X > x) = q: -ndtri(q), as ``scipy.stats.norm.isf`` computes it."""
    from scipy.special import ndtri

    return -ndtri(np.asarray(q, dtype=float))


def detectable(snr: float | None) -> bool | None:
    """The criterion: ``snr >= ROSE_SNR`` (None when the SNR is undefined)."""
    return None if snr is None else bool(snr >= ROSE_SNR)


def verdict_words(snr: float | None, snr_stderr: float | None = None) -> str:
    """``detectable (SNR 7.2 ± 0.3)``, ``not detectable (SNR 0.4)``, or, without noise,
    ``no imager noise: SNR undefined``; ``within the Monte Carlo error of the threshold`` is added
    when the SNR lies within two standard errors of `ROSE_SNR`."""
    if snr is None:
        return "no imager noise: SNR undefined"
    err = f" ± {snr_stderr:.2g}" if snr_stderr is not None else ""
    words = f"{'detectable' if detectable(snr) else 'not detectable'} (SNR {snr:.3g}{err})"
    if snr_stderr is not None and abs(snr - ROSE_SNR) < 2.0 * snr_stderr:
        words += ", within the Monte Carlo error of the threshold: render more samples"
    return words


def contrast_verdict(pair: str, by_channel: dict[str, tuple[float | None, ...]]) -> str:
    """One line in words for a contrast over its channels, the best first:
    ``beacon - runway: detectable in Ey2 (SNR 7.2 ± 0.3), I (SNR 6.1 ± 0.2); not in Ex2 (SNR 3.1 ±
    0.2)``. ``by_channel``: channel -> (snr, snr_stderr) as `verdict_words` takes them, or (snr,
    snr_stderr, ideal contrast [K]), whose contrast then leads (``-25.3 K, SNR 7.2 ± 0.3``); channels
    whose SNR lies within two standard errors of `ROSE_SNR` are named after a ``near the
    threshold`` note."""
    rows = {c: (tuple(v) + (None,))[:3] for c, v in by_channel.items()}
    known = sorted(((c, s, e) for c, (s, e, _) in rows.items() if s is not None), key=lambda t: -t[1])
    if not known:
        return f"{pair}: {verdict_words(None)}"

    def snr(c, s, e):  # as `verdict_words` writes it, after the ideal contrast when given
        k = rows[c][2]
        return (f"{k:+.3g} K, " if k is not None else "") + f"SNR {s:.3g}" + (f" ± {e:.2g}" if e is not None else "")

    yes = [f"{c} ({snr(c, s, e)})" for c, s, e in known if detectable(s)]
    no = [f"{c} ({snr(c, s, e)})" for c, s, e in known if not detectable(s)]
    words = (
        (f"detectable in {', '.join(yes)}" + (f"; not in {', '.join(no)}" if no else ""))
        if yes
        else f"not detectable in {', '.join(no)}"
    )
    near = [c for c, s, e in known if e is not None and abs(s - ROSE_SNR) < 2.0 * e]
    if near:
        words += f" ({', '.join(near)} within the Monte Carlo error of the threshold: render more samples)"
    return f"{pair}: {words}"


def detection_limit(
    xs: np.typing.ArrayLike, snrs: np.typing.ArrayLike, snr_stderrs: list[float | None] | None = None
) -> dict:
    """Where along a swept axis a contrast stops being detected (`ROSE_SNR`): its detection range
    (or frequency, aperture, integration time).

    Parameters
    ----------
    xs : sequence of float
        The swept values, increasing.
    snrs : sequence of float
        The contrast's SNR at each.
    snr_stderrs : sequence of float or None, optional
        Their Monte Carlo standard errors.

    Returns
    -------
    dict
        ``kind``: ``"all"`` (detected at every value), ``"none"`` (at none), ``"limit"``;
        for a limit: ``detected_x`` (the last detected value before the threshold is crossed,
        going in the direction the SNR falls), ``missed_x`` (the next value, not detected),
        ``crossing_x`` (SNR = `ROSE_SNR` by linear interpolation of the SNR between the two),
        ``spacing_error`` (half the bracket: the interpolation's share), ``mc_error`` (the SNR's
        standard error at the two ends, interpolated, over the slope |dSNR/dx|: the Monte Carlo's
        share), ``error`` (the two in quadrature), ``falls_with_x`` (True: the SNR falls as x
        grows, the limit is a maximum, as a range; False: a minimum, as an aperture).
    """
    x = np.asarray(xs, dtype=float)
    s = np.asarray(snrs, dtype=float)
    e = (
        np.zeros_like(s)
        if snr_stderrs is None
        else np.array([np.nan if v is None else v for v in snr_stderrs], dtype=float)
    )
    det = s >= ROSE_SNR
    if det.all():
        return {"kind": "all"}
    if not det.any():
        return {"kind": "none"}
    falls = bool(s[-1] < s[0]) if s[-1] != s[0] else bool(det[0])
    order = np.arange(x.size) if falls else np.arange(x.size)[::-1]
    # the first step, going the way the SNR falls, from a detected value to a missed one
    i = next(int(order[k]) for k in range(len(order) - 1) if det[order[k]] and not det[order[k + 1]])
    j = int(order[list(order).index(i) + 1])
    slope = (s[j] - s[i]) / (x[j] - x[i])
    t = (ROSE_SNR - s[i]) / (s[j] - s[i])
    crossing = x[i] + t * (x[j] - x[i])
    spacing = abs(x[j] - x[i]) / 2.0
    e_at = (1 - t) * e[i] + t * e[j]
    mc = float(e_at / abs(slope)) if np.isfinite(e_at) and slope != 0 else float("nan")
    return {
        "kind": "limit",
        "detected_x": float(x[i]),
        "missed_x": float(x[j]),
        "crossing_x": float(crossing),
        "spacing_error": float(spacing),
        "mc_error": mc,
        "error": float(np.hypot(spacing, mc)) if np.isfinite(mc) else float(spacing),
        "falls_with_x": falls,
    }

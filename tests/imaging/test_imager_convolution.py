"""`imaging.imager.fftconvolve` against SciPy's own `scipy.signal.fftconvolve` (an independent
implementation of the same thing), and the start-up cost it exists to avoid."""

import subprocess
import sys

import numpy as np
import pytest
from scipy import signal

from pmmw.imaging.imager import blur, fftconvolve


@pytest.mark.parametrize(
    "image_shape,kernel_shape",
    [
        ((40, 37), (7, 7)),
        ((9, 9), (1, 1)),
        ((5, 31), (11, 11)),
        ((1, 20), (3, 3)),
        ((16, 16), (16, 16)),
        ((3, 4), (9, 9)),
    ],
)
def test_same_numbers_as_scipy_signal(image_shape, kernel_shape):
    # tolerance: none (array_equal): the same FFT lengths and operations in the same order give the
    # same floating-point numbers, which is what keeps a render's image unchanged to the bit
    rng = np.random.default_rng(3)
    a, k = rng.normal(300.0, 20.0, image_shape), rng.random(kernel_shape)
    assert np.array_equal(fftconvolve(a, k, mode="same"), signal.fftconvolve(a, k, mode="same"))
    # control: a kernel flipped in both axes is another convolution, so the comparison can fail
    if kernel_shape[0] > 1:
        assert not np.array_equal(fftconvolve(a, k[::-1, ::-1]), signal.fftconvolve(a, k, mode="same"))


def test_blur_of_a_point_is_the_kernel():
    # tolerance 1e-12 K on a 1 K point: FFT round-off of a 41 x 41 transform
    img = np.zeros((41, 41))
    img[20, 20] = 1.0
    k = np.outer([1.0, 2.0, 1.0], [1.0, 2.0, 1.0]) / 16.0
    np.testing.assert_allclose(blur(img, k)[19:22, 19:22], k, atol=1e-12)


def test_the_imager_model_does_not_import_scipy_signal():
    code = (
        "import sys, numpy as np\n"
        "from pmmw.imaging.imager import apply_imager\n"
        "ideal = {c: np.full((20, 20), 280.0) for c in ('Ex2', 'Ey2', 'U', 'V')}\n"
        "apply_imager(ideal, pixel_angle=1e-3, k0=2e3, aperture_diameter=0.6, noise=1.0, seed=1)\n"
        "print('scipy.signal' in sys.modules, 'scipy.fft' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "True"]  # scipy.fft loaded: the model did convolve (the control)


def test_a_kept_kernel_spectrum_gives_the_same_numbers():
    # tolerance: none (array_equal): the second image reuses the kernel's kept transform, which
    # must be the transform of this kernel (not of the previous one: the control)
    rng = np.random.default_rng(5)
    k1, k2 = rng.random((9, 9)), rng.random((9, 9))
    for _ in range(2):
        for k in (k1, k2, k1[::-1, ::-1]):
            a = rng.normal(size=(30, 30))
            assert np.array_equal(fftconvolve(a, k), signal.fftconvolve(a, k, mode="same"))
    assert not np.array_equal(fftconvolve(a, k2), signal.fftconvolve(a, k1, mode="same"))


def _padded_reference(img, k):
    """The blur as the imager model defines it, by SciPy: the image mirrored about its edges by the
    kernel's radius (numpy's symmetric padding), convolved, the centre cut out."""
    r = k.shape[0] // 2
    h, w = img.shape
    return signal.fftconvolve(np.pad(img, r, mode="symmetric"), k, mode="same")[r : r + h, r : r + w]


@pytest.mark.parametrize("image_shape", [(40, 37), (16, 24), (7, 60), (1, 5), (3, 4)])
def test_a_mirror_symmetric_kernel_blurs_as_scipy_does_on_the_mirrored_image(image_shape):
    """`blur` of a mirror-symmetric kernel (the Airy PSF) takes the DCT path (`mirror_symmetric`),
    the kernel (25 px) wider than the image, up to 25 times on the 1-row image (its wrap onto the
    mirrored image's period);
    against SciPy's convolution of the padded image. Tolerance 1e-10 K on 300 K images: both are
    FFTs of at most a few hundred points, whose round-off is about eps x log2(n) x 300 K, 1e-12 K.
    The control: the same kernel shifted by one pixel (no longer symmetric: the padded FFT path)
    agrees with its own reference and differs from the symmetric one by far more."""
    from pmmw.imaging.imager import mirror_symmetric, psf_kernel

    rng = np.random.default_rng(11)
    img = rng.normal(300.0, 20.0, image_shape)
    k = psf_kernel(1e-3, 2 * np.pi * 35e9 / 3e8, 0.3)  # 1 mrad pixels: the Airy core about 3 px
    k = k[k.shape[0] // 2 - 12 : k.shape[0] // 2 + 13, k.shape[1] // 2 - 12 : k.shape[1] // 2 + 13]  # 25 x 25
    k /= k.sum()
    assert mirror_symmetric(k)
    np.testing.assert_allclose(blur(img, k), _padded_reference(img, k), rtol=0, atol=1e-10)
    shifted = np.zeros_like(k)
    shifted[:, 1:] = k[:, :-1]
    assert not mirror_symmetric(shifted)
    np.testing.assert_allclose(blur(img, shifted), _padded_reference(img, shifted), rtol=0, atol=1e-10)
    if image_shape[1] > 1:
        assert np.abs(blur(img, shifted) - _padded_reference(img, k)).max() > 1e-3


def test_the_landing_s_kernel_wider_than_its_image():
    """The landing's Airy kernel (0.6 m at 95 GHz, 10 deg over 500 px: 513 x 513, the 256 px
    radius cap) on a 120 x 90 image, wrapped more than twice onto the mirrored image; tolerance as
    above, the sums being of a 513-point kernel: 1e-9 K."""
    from pmmw.imaging.imager import psf_kernel

    k = psf_kernel(np.radians(10.0) / 500, 2 * np.pi * 95e9 / 299_792_458.0, 0.6)
    assert k.shape == (513, 513)
    img = np.random.default_rng(2).normal(250.0, 30.0, (90, 120))
    np.testing.assert_allclose(blur(img, k), _padded_reference(img, k), rtol=0, atol=1e-9)

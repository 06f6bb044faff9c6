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

"""The array types of pmmw's annotations, one home for them (``numpy.typing``): ``FloatArray``
(float64) and ``ComplexArray`` (complex128) ndarrays of any shape."""

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
ComplexArray = npt.NDArray[np.complex128]

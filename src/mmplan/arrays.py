"""Array type aliases shared by the whole package (defined once, here, at the bottom)."""

import numpy as np
from numpy.typing import NDArray

#: A float64 array (its shape is stated where it is used).
Array = NDArray[np.float64]

#: A boolean array.
BoolArray = NDArray[np.bool_]

__all__ = ["Array", "BoolArray"]

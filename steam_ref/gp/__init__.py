"""The GP motion prior: transition, process noise, interpolation.  [YIB Sec. II-A, II-B]"""

from .interpolate import interpolate_state, interpolation_matrices
from .prior import process_noise, process_noise_inverse, transition

__all__ = [
    "transition",
    "process_noise",
    "process_noise_inverse",
    "interpolation_matrices",
    "interpolate_state",
]

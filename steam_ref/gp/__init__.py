"""The GP motion prior: transition, process noise, interpolation.  [YIB Sec. II-A, II-B]"""

from .interpolate import (
    interpolate_covariance,
    interpolate_covariance_sde,
    interpolate_state,
    interpolate_state_sde,
    interpolation_matrices,
    interpolation_matrices_sde,
)
from .prior import process_noise, process_noise_inverse, process_noise_sqrt_information, transition
from .sde import LinearSDE, dense_kernel

__all__ = [
    "transition",
    "process_noise",
    "process_noise_inverse",
    "process_noise_sqrt_information",
    "interpolation_matrices",
    "interpolate_state",
    "interpolate_covariance",
    "LinearSDE",
    "dense_kernel",
    "interpolation_matrices_sde",
    "interpolate_state_sde",
    "interpolate_covariance_sde",
]

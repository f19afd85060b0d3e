"""The GP motion prior: transition, process noise, interpolation, extrapolation.  [YIB Sec. II-A, II-B]"""

from .interpolate import (
    extrapolate_covariance_sde,
    extrapolate_state_sde,
    interpolate_covariance,
    interpolate_covariance_sde,
    interpolate_state,
    interpolate_state_sde,
    interpolation_matrices,
    interpolation_matrices_many,
    interpolation_matrices_sde,
)
from .models import (
    ClosedForm,
    singer_process_noise,
    singer_transition,
    wnoj_process_noise,
    wnoj_process_noise_inverse,
    wnoj_transition,
)
from .prior import process_noise, process_noise_inverse, process_noise_sqrt_information, transition
from .sde import LinearSDE, dense_kernel

__all__ = [
    "transition",
    "process_noise",
    "process_noise_inverse",
    "process_noise_sqrt_information",
    "interpolation_matrices",
    "interpolation_matrices_many",
    "interpolate_state",
    "interpolate_covariance",
    "LinearSDE",
    "dense_kernel",
    "interpolation_matrices_sde",
    "interpolate_state_sde",
    "interpolate_covariance_sde",
    "extrapolate_state_sde",
    "extrapolate_covariance_sde",
    "ClosedForm",
    "wnoj_transition",
    "wnoj_process_noise",
    "wnoj_process_noise_inverse",
    "singer_transition",
    "singer_process_noise",
]

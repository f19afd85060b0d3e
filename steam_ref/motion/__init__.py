"""Motion priors, each one object: the GP prior of a trajectory's states behind one protocol.  [YIB Sec. II]

- :mod:`.base`: :class:`MotionPrior`, the protocol: the state's kind and size, the prior factor between two
  states, the interpolated factor, state and covariance, the prediction after the last state, what a velocity or
  pose reading becomes on the state, the first state's prior, a new state's value, the world-frame pose and
  velocity of a state, drawing a task from the model. ``reading_inside`` (the reading a factor holds through
  every wrapper a prior puts it in).
- :mod:`.vector`: :class:`VectorPrior`, the vector-space prior of any LTI SDE: the paper's WNOA (from Qc, its
  memoised closed forms), WNOJ, Singer's model, any (A, F, Qc, v).
- :mod:`.lie_group`: :class:`LieGroupWnoa`, WNOA on any Lie group through local variables (both residuals);
  the table's 'se2' is ``LieGroupWnoa(SE2, qc, residual)``.
- :mod:`.lie_accel`: :class:`LieGroupAccelPrior`, a three-block LTI model (WNOJ, Singer) on any Lie group through
  exact local variables, states [pose; body twist; its rate]; the table's 'se2-wnoj', 'se3-wnoj', 'se2-singer',
  'se3-singer'.
- :mod:`.table`: :data:`MOTION_PRIORS` (the names a user types → constructors), :func:`motion_prior`,
  :func:`as_motion_prior` (the one conversion of a prior argument), :func:`predict_state`, :func:`turned_state`
  (a state with the world turned about its origin).
"""

from .base import MotionPrior, is_interpolated, reading_inside
from .lie_accel import LieGroupAccelPrior
from .lie_group import RESIDUALS, LieGroupWnoa
from .table import MOTION_PRIORS, PriorChoice, as_motion_prior, motion_prior, predict_state, turned_state
from .vector import VectorPrior

__all__ = [
    "MotionPrior",
    "VectorPrior",
    "LieGroupWnoa",
    "LieGroupAccelPrior",
    "RESIDUALS",
    "MOTION_PRIORS",
    "PriorChoice",
    "motion_prior",
    "as_motion_prior",
    "predict_state",
    "turned_state",
    "reading_inside",
    "is_interpolated",
]

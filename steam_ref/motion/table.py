"""The priors by the names a user types, the one conversion of a prior argument, and a new state's start.

- :data:`MOTION_PRIORS`: name → :class:`PriorChoice` (its constructor and the options it takes beside Qc). A new
  prior is its name in :data:`steam_ref.choices.MOTION_PRIOR_NAMES` (its options, one line saying what it is, its
  dimensions: what the command line's ``--prior`` choices and help read, without loading this module) and its
  constructor here (docs/architecture.md, "Add a motion prior"); ``PaperSetup.prior`` and :func:`motion_prior`
  read it.
- :func:`as_motion_prior`: what every API that takes a prior accepts (a :class:`~steam_ref.motion.MotionPrior`,
  or, as before the protocol, Qc of the paper's WNOA prior or a :class:`~steam_ref.gp.LinearSDE`), as a
  :class:`~steam_ref.motion.MotionPrior`.
- :func:`predict_state`: a new state's starting value, the prior's prediction [YIB Eq. 14, 22], right for every
  kind of state (on SE(2) along the arc of the twist, not the straight line).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import lie
from ..arguments import finite, number, real_array
from ..choices import MOTION_PRIOR_NAMES, SINGER_TIME_CONSTANT
from ..errors import ShapeError, SteamError
from ..gp.sde import LinearSDE, check_prior
from ..lie import SE2
from ..manifold import VECTOR, Manifold
from .base import MotionPrior
from .lie_accel import LieGroupAccelPrior
from .lie_group import LieGroupWnoa
from .vector import VectorPrior

__all__ = ["PriorChoice", "MOTION_PRIORS", "motion_prior", "as_motion_prior", "predict_state", "turned_state"]


@dataclass(frozen=True)
class PriorChoice:
    """A prior a user can name: ``make(qc, **options)`` builds it; ``options`` are the keywords it takes beside
    Qc (as ``PaperSetup`` and the command line name them); ``what`` says it in one line; ``dimensions``: of the
    space its states' body moves in (2: a pose [x, y, θ] or on SE(2); 3: on SE(3)), a data set's own
    (``DataSet.dimensions``) when the prior runs on it. All but ``make`` are its name's
    :class:`~steam_ref.choices.PriorName`, where the command line's parser reads them."""

    make: Callable[..., MotionPrior]
    options: tuple[str, ...]
    what: str
    dimensions: int = 2


def _singer(qc: ArrayLike, singer_time_constant: float = SINGER_TIME_CONSTANT) -> MotionPrior:
    return VectorPrior.singer(qc, time_constant=singer_time_constant)


def _se2(qc: ArrayLike, se2_residual: str = "local-variable") -> MotionPrior:
    return LieGroupWnoa(SE2, qc, residual=se2_residual)


def _se3(qc: ArrayLike) -> MotionPrior:
    return LieGroupWnoa(lie.SE3V, qc)  # SE(3) loads when a user names it (lie/__init__.py, PEP 562)


def _se3_simplified(qc: ArrayLike) -> MotionPrior:
    return LieGroupWnoa(lie.SE3V, qc, residual="simplified")


def _se2_wnoj(qc: ArrayLike) -> MotionPrior:
    return LieGroupAccelPrior.wnoj(SE2, qc)


def _se3_wnoj(qc: ArrayLike) -> MotionPrior:
    return LieGroupAccelPrior.wnoj(lie.SE3V, qc)


def _se2_singer(qc: ArrayLike, singer_time_constant: float = SINGER_TIME_CONSTANT) -> MotionPrior:
    return LieGroupAccelPrior.singer(SE2, qc, singer_time_constant)


def _se3_singer(qc: ArrayLike, singer_time_constant: float = SINGER_TIME_CONSTANT) -> MotionPrior:
    return LieGroupAccelPrior.singer(lie.SE3V, qc, singer_time_constant)


# Each name's constructor; its options, line and dimensions are steam_ref.choices.MOTION_PRIOR_NAMES' (a name
# without a constructor here fails on import; tests/test_choices.py checks that no constructor goes unnamed).
_MAKERS: dict[str, Callable[..., MotionPrior]] = {
    "wnoa": VectorPrior.wnoa,
    "wnoj": VectorPrior.wnoj,
    "singer": _singer,
    "se2": _se2,
    "se2-wnoj": _se2_wnoj,
    "se2-singer": _se2_singer,
    "se3": _se3,
    "se3-simplified": _se3_simplified,
    "se3-wnoj": _se3_wnoj,
    "se3-singer": _se3_singer,
}

MOTION_PRIORS: dict[str, PriorChoice] = {
    name: PriorChoice(_MAKERS[name], named.options, named.what, named.dimensions)
    for name, named in MOTION_PRIOR_NAMES.items()
}


def motion_prior(name: str, qc: ArrayLike, **options: object) -> MotionPrior:
    """The prior called ``name`` (:data:`MOTION_PRIORS`) with Qc ``qc`` and its ``options``; SteamError names an
    unknown prior, or an option it does not take."""
    choice = MOTION_PRIORS.get(name) if isinstance(name, str) else None
    if choice is None:
        raise SteamError(f"unknown motion prior {name!r}; use one of {', '.join(MOTION_PRIORS)}")
    foreign = [option for option in options if option not in choice.options]
    if foreign:
        takes = ", ".join(choice.options) or "none"
        raise SteamError(f"the motion prior {name!r} takes no option {foreign[0]!r} (its options: {takes})")
    return choice.make(qc, **options)


def as_motion_prior(prior: MotionPrior | ArrayLike | LinearSDE, name: str = "prior") -> MotionPrior:
    """``prior`` as a :class:`MotionPrior`: one as it is; Qc (d, d) as the paper's WNOA prior (its closed forms);
    a :class:`~steam_ref.gp.LinearSDE` as its vector-space prior."""
    if isinstance(prior, MotionPrior):
        return prior
    try:
        return VectorPrior(check_prior(prior, name))
    except SteamError as exc:
        raise type(exc)(f"{exc} (or a steam_ref.motion.MotionPrior)") from None


def predict_state(x_prev: ArrayLike, dt: float, prior: MotionPrior | ArrayLike | LinearSDE) -> NDArray:
    """The starting value of a new state ``dt`` after ``x_prev``: the prior's mean there.  [YIB Eq. 14, 22]

    ``prior`` is a :class:`MotionPrior` (``motion_prior('se2', qc)``: the pose moves along the arc of its body
    twist, T Exp(dt ϖ)), or Qc (the paper's WNOA prior: [x, y, θ] += dt [ẋ, ẏ, θ̇], the velocity kept) or any
    :class:`~steam_ref.gp.LinearSDE` (Φ(dt) x_prev + v(dt)). Give the new state this value in the update that adds
    it: the prior factor to it then has a zero error, and the measurements pull it from there. Returns a new
    (n,) array; dt must be > 0.
    """
    prior, dt = as_motion_prior(prior), number("dt", dt)
    if not dt > 0:
        raise SteamError(f"dt must be > 0 (the new state comes after x_prev), got dt={dt!r}")
    x = real_array("x_prev", x_prev)
    if x.shape != (prior.state_dim,):
        raise ShapeError(f"x_prev must be a finite ({prior.state_dim},) vector, got shape {x.shape}")
    return np.asarray(prior.predict(finite("x_prev", x), dt))


def turned_state(x: ArrayLike, kind: Manifold, angle: float) -> NDArray:
    """The state ``x`` of a motion prior (its kind ``kind``) with the world turned by ``angle`` about its origin:
    how the whole estimate turns (``paper.converge.rotated``). A vector state (pose, world velocity, acceleration:
    blocks of [x, y, θ] and their derivatives) rotates every block's [x, y] and shifts its heading, unwrapped; a
    state of any other kind turns as its kind says (``turned(x, angle)``: ``GroupState.turned`` turns the pose and
    keeps the body twist). SteamError for a kind that does not say."""
    x = np.array(x, dtype=float)
    if kind is not VECTOR:
        turned = getattr(kind, "turned", None)
        if turned is None:
            raise SteamError(f"a state of kind {kind!r} does not say how it turns about the origin (no turned method)")
        return np.asarray(turned(x, angle))
    c, s = np.cos(angle), np.sin(angle)
    for b in range(0, len(x), 3):
        x[b], x[b + 1] = c * x[b] - s * x[b + 1], s * x[b] + c * x[b + 1]
    x[2] += angle
    return x

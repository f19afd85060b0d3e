"""The kit's language-neutral specs (keys, factors, values) as steam_ref objects: every suite's, one table.

A key is a string: ``"x3"`` is trajectory state 3, ``"l1"`` landmark 1. A factor is a dict with a
``type``, its ``keys`` and the numbers its model needs (docs/conformance.md lists them); :data:`FACTORS`
maps each type to its steam_ref factor and the kind (manifold) of each of its keys:

    gp_prior       keys [x1, x2], dt, qc                      e = x₂ - Φ x₁      [YIB Eq. 22, 30-31]
    prior          keys [k], mean, noise                      e = θ - mean       [YIB Eq. 4]
    odometry       keys [x], measured [v, ω], noise           [YIB Eq. 32]
    velocity       keys [x], measured [v, v_lat, ω], noise    the scripts' projected velocity (forward, lateral, yaw rate)
    range          keys [x, l], measured r, noise             [YIB Eq. 33]
    bearing        keys [x, l], measured b, noise             error wrapped to [-π, π)
    bearing_range  keys [x, l], measured [b, r], noise
    interpolated   keys [x1, x2, (l)], t1, t2, tau, qc, inner (a measurement spec without keys)  [YIB Eq. 29]
    se2_prior        keys [x1, x2] SE(2) states, dt, qc (3×3 on the body twist), model   e = γ₂ - Φ(Δt) γ₁
    se2_state_prior  keys [x] an SE(2) state, mean, sigmas (6)                         e = x ⊖ mean
    se2_range        keys [x, l], x an SE(2) state, measured, sigma                    e = ‖l - p‖ - r
    se3_prior        keys [x1, x2] SE(3) states, dt, qc (6×6), model                  e = γ₂ - Φ(Δt) γ₁   (kit v5)
    se3_wnoj_prior   keys [x1, x2] SE(3) states with an acceleration, dt, qc (6×6)     e = γ₂ - Φ(Δt) γ₁   (kit v5)
    se3_state_prior  keys [x] an SE(3) state, mean, sigmas (12)                        e = x ⊖ mean        (kit v5)
    se3_velocity     keys [x] an SE(3) state, measured (6), sigmas (6)                 e = ϖ - z           (kit v5)

where noise is ``sigma`` (a scalar), ``sigmas`` (one per error entry) or ``covariance`` (a matrix),
and a measurement may carry ``loss``: ``{"type": "huber", "k": k}`` or ``{"type": "tukey", "c": c}``.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Mapping, Sequence

import numpy as np

from .. import lie
from ..errors import SteamError
from ..factors import (
    BearingFactor,
    BearingRangeFactor,
    BodyVelocityFactor,
    Factor,
    GPPriorFactor,
    InterpolatedFactor,
    LiePriorFactor,
    LieStatePrior,
    OdometryFactor,
    PoseReading,
    PriorFactor,
    RangeFactor,
    VelocityFactor,
)
from ..factors.lie_prior import LieAccelPriorFactor
from ..gp import LinearSDE
from ..lie import SE2, SE2_STATE, GroupState
from ..linear.ordering import Ordering
from ..manifold import VECTOR, Manifold
from ..robust import Huber, RobustLoss, Tukey
from ..variables import Key, L, Values, X

__all__ = ["FACTORS", "key", "key_name", "factor", "key_kinds", "values", "ordering"]

_KEY = re.compile(r"^([xl])(\d+)$")


def key(name: str) -> Key:
    """'x3' → X(3), 'l1' → L(1)."""
    m = _KEY.match(str(name))
    if m is None:
        raise SteamError(f"a key is 'x<i>' or 'l<j>', got {name!r}")
    return (X if m.group(1) == "x" else L)(int(m.group(2)))


def key_name(k: Key) -> str:
    """X(3) → 'x3'."""
    return f"{k.symbol}{k.index}"


def _loss(spec: Mapping | None) -> RobustLoss | None:
    if spec is None:
        return None
    if spec["type"] == "huber":
        return Huber(float(spec["k"]))
    if spec["type"] == "tukey":
        return Tukey(float(spec["c"]))
    raise SteamError(f"unknown loss type {spec['type']!r}")


def _noise(spec: Mapping):
    if "covariance" in spec:
        return np.asarray(spec["covariance"], float)
    if "sigmas" in spec:
        return np.asarray(spec["sigmas"], float)
    return float(spec["sigma"])


def _gp_prior(spec: Mapping, keys: Sequence[Key]) -> Factor:
    return GPPriorFactor.wnoa(keys[0], keys[1], float(spec["dt"]), np.asarray(spec["qc"], float))


def _prior(spec: Mapping, keys: Sequence[Key]) -> Factor:
    return PriorFactor.create(keys[0], np.asarray(spec["mean"], float), _noise(spec), loss=_loss(spec.get("loss")))


def _measurement(create: Callable, measured: Callable) -> Callable[[Mapping, Sequence[Key]], Factor]:
    """A measurement's builder: ``create(*keys, measured(y), noise, loss=loss)``."""

    def build(spec: Mapping, keys: Sequence[Key]) -> Factor:
        return create(*keys, *measured(spec["measured"]), _noise(spec), loss=_loss(spec.get("loss")))

    return build


def _interpolated(spec: Mapping, keys: Sequence[Key]) -> Factor:
    stand_in = X(10**9)  # the missing state x(τ): not a variable of any graph
    inner = factor({**spec["inner"], "keys": []}, [stand_in, *keys[2:]])
    t1, t2, tau = (float(spec[k]) for k in ("t1", "t2", "tau"))
    return InterpolatedFactor.create(inner, keys[0], keys[1], t1, t2, tau, np.asarray(spec["qc"], float))


def _lie_prior(spec: Mapping, keys: Sequence[Key]) -> Factor:
    dt, qc = float(spec["dt"]), np.asarray(spec["qc"], float)
    return LiePriorFactor.create(keys[0], keys[1], dt, qc, spec["model"], group=SE2)


def _lie_state_prior(spec: Mapping, keys: Sequence[Key]) -> Factor:
    return LieStatePrior.create(keys[0], np.asarray(spec["mean"], float), np.asarray(spec["sigmas"], float), group=SE2)


def _pose_range(spec: Mapping, keys: Sequence[Key]) -> Factor:
    return PoseReading.range(keys[0], keys[1], float(spec["measured"]), float(spec["sigma"]), group=SE2)


def _se3_prior(spec: Mapping, keys: Sequence[Key]) -> Factor:
    dt, qc = float(spec["dt"]), np.asarray(spec["qc"], float)
    return LiePriorFactor.create(keys[0], keys[1], dt, qc, spec["model"], group=lie.SE3)


def _se3_wnoj_prior(spec: Mapping, keys: Sequence[Key]) -> Factor:
    sde = LinearSDE.wnoj(np.asarray(spec["qc"], float))
    return LieAccelPriorFactor.create(keys[0], keys[1], float(spec["dt"]), sde, group=lie.SE3)


def _se3_state_prior(spec: Mapping, keys: Sequence[Key]) -> Factor:
    mean, sigmas = np.asarray(spec["mean"], float), np.asarray(spec["sigmas"], float)
    return LieStatePrior.create(keys[0], mean, sigmas, group=lie.SE3)


def _se3_velocity(spec: Mapping, keys: Sequence[Key]) -> Factor:
    measured, sigmas = np.asarray(spec["measured"], float), np.asarray(spec["sigmas"], float)
    return BodyVelocityFactor.create(keys[0], measured, sigmas, group=lie.SE3)


_SE3, _SE3_ACC = GroupState(lie.SE3), GroupState(lie.SE3, 2)  # the states of the se3 suite (kit v5)

_V = VECTOR
_vector, _number = (lambda y: [y]), (lambda y: [float(y)])  # a reading as given; a number
# Factor type → (its steam_ref factor from the spec and its keys, the kind of each key). A new type is a row.
FACTORS: dict[str, tuple[Callable[[Mapping, Sequence[Key]], Factor], tuple[Manifold, ...]]] = {
    "gp_prior": (_gp_prior, (_V, _V)),
    "prior": (_prior, (_V,)),
    "odometry": (_measurement(OdometryFactor.create, _vector), (_V,)),
    "velocity": (_measurement(VelocityFactor.create, _vector), (_V,)),
    "range": (_measurement(RangeFactor.create, _number), (_V, _V)),
    "bearing": (_measurement(BearingFactor.create, _number), (_V, _V)),
    "bearing_range": (_measurement(BearingRangeFactor.create, lambda y: [float(y[0]), float(y[1])]), (_V, _V)),
    "interpolated": (_interpolated, (_V, _V, _V)),
    "se2_prior": (_lie_prior, (SE2_STATE, SE2_STATE)),
    "se2_state_prior": (_lie_state_prior, (SE2_STATE,)),
    "se2_range": (_pose_range, (SE2_STATE, _V)),
    "se3_prior": (_se3_prior, (_SE3, _SE3)),
    "se3_wnoj_prior": (_se3_wnoj_prior, (_SE3_ACC, _SE3_ACC)),
    "se3_state_prior": (_se3_state_prior, (_SE3,)),
    "se3_velocity": (_se3_velocity, (_SE3,)),
}


def _type(spec: Mapping) -> tuple[Callable[[Mapping, Sequence[Key]], Factor], tuple[Manifold, ...]]:
    kind = spec["type"]
    if kind not in FACTORS:
        raise SteamError(f"unknown factor type {kind!r}; the kit's are {', '.join(FACTORS)}")
    return FACTORS[kind]


def factor(spec: Mapping, keys: Sequence[Key] | None = None) -> Factor:
    """A steam_ref factor from its spec (``keys``: instead of the spec's own)."""
    build, _ = _type(spec)
    return build(spec, [key(k) for k in spec["keys"]] if keys is None else keys)


def key_kinds(specs: Iterable[Mapping]) -> dict[Key, Manifold]:
    """The kind of every key the factor specs name that is not a plain vector (an SE(2) state)."""
    out: dict[Key, Manifold] = {}
    for spec in specs:
        for name, kind in zip(spec["keys"], _type(spec)[1], strict=False):
            if kind is not VECTOR:
                out[key(name)] = kind
    return out


def values(spec: Mapping[str, Sequence[float]], kinds: Mapping[Key, Manifold] | None = None) -> Values:
    """Values from key name → vector; ``kinds``: of the keys that are not plain vectors (:func:`key_kinds`)."""
    given = {key(k): np.asarray(v, float) for k, v in spec.items()}
    return Values(given, kinds={k: m for k, m in (kinds or {}).items() if k in given})


def ordering(names: Sequence[str], dims: Mapping[str, int]) -> Ordering:
    """An Ordering of the named variables, in the order given."""
    return Ordering(tuple(key(k) for k in names), tuple(int(dims[k]) for k in names))

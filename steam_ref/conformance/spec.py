"""The kit's language-neutral specs (keys, factors, values) as steam_ref objects: every suite's, one table.

A key is a string: ``"x3"`` is trajectory state 3, ``"l1"`` landmark 1. A factor is a dict with a
``type``, its ``keys`` and the numbers its model needs (docs/conformance.md lists them); :data:`FACTORS`
maps each type to its steam_ref factor and the kind (manifold) of each of its keys::

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
    se2_range        keys [x, l], x an SE(2) state, measured, noise                    e = ‖l - p‖ - r
    se2_bearing      keys [x, l], x an SE(2) state, measured, noise     bearing, error wrapped to [-π, π)  (kit v5)
    se2_bearing_range keys [x, l], x an SE(2) state, measured [b, r], noise                            (kit v5)
    se2_velocity     keys [x] an SE(2) state, measured (3), noise                      e = ϖ - z           (kit v5)
    se2_interpolated keys [x1, x2, (l)] SE(2) states, t1, t2, tau, qc, model, inner (an se2 reading without keys)
                     e = e_inner(x(τ), ...), x(τ) the local GP's mean                                  (kit v5)
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
from dataclasses import dataclass
from functools import partial

import numpy as np
from numpy.typing import NDArray

from .. import lie
from ..errors import SteamError
from ..factors import (
    BearingFactor,
    BearingRangeFactor,
    BodyVelocityFactor,
    Factor,
    GPPriorFactor,
    InterpolatedFactor,
    LieInterpolatedFactor,
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
from ..lie import SE2, SE2_STATE, GroupState, LieGroup
from ..linear.ordering import Ordering
from ..manifold import VECTOR, Manifold
from ..robust import Huber, RobustLoss, Tukey
from ..variables import Key, L, Values, X

__all__ = [
    "FACTORS",
    "SOLVER_FORMS",
    "key",
    "key_name",
    "factor",
    "key_kinds",
    "values",
    "solver_factor",
    "solver_values",
    "kit_value",
    "ordering",
]

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
    return PoseReading.range(keys[0], keys[1], float(spec["measured"]), _noise(spec), group=SE2)


def _pose_bearing(spec: Mapping, keys: Sequence[Key]) -> Factor:
    return PoseReading.bearing(keys[0], keys[1], float(spec["measured"]), _noise(spec), group=SE2)


def _pose_bearing_range(spec: Mapping, keys: Sequence[Key]) -> Factor:
    b, r = (float(v) for v in spec["measured"])
    return PoseReading.bearing_range(keys[0], keys[1], b, r, _noise(spec), group=SE2)


def _twist_reading(spec: Mapping, keys: Sequence[Key]) -> Factor:
    return BodyVelocityFactor.create(keys[0], np.asarray(spec["measured"], float), _noise(spec), group=SE2)


def _lie_interpolated(spec: Mapping, keys: Sequence[Key]) -> Factor:
    """A reading of an SE(2) state at τ moved onto the states at t1 and t2 (the local GP of the spec's model)."""
    inner = factor({**spec["inner"], "keys": []}, [X(10**9), *keys[2:]])  # X(10**9) stands for the state at τ
    t1, t2, tau = (float(spec[k]) for k in ("t1", "t2", "tau"))
    qc = np.asarray(spec["qc"], float)
    return LieInterpolatedFactor.create(inner, keys[0], keys[1], t1, t2, tau, qc, spec["model"], group=SE2)


def _se3_prior(group: LieGroup, spec: Mapping, keys: Sequence[Key]) -> Factor:
    dt, qc = float(spec["dt"]), np.asarray(spec["qc"], float)
    return LiePriorFactor.create(keys[0], keys[1], dt, qc, spec["model"], group=group)


def _se3_wnoj_prior(group: LieGroup, spec: Mapping, keys: Sequence[Key]) -> Factor:
    sde = LinearSDE.wnoj(np.asarray(spec["qc"], float))
    return LieAccelPriorFactor.create(keys[0], keys[1], float(spec["dt"]), sde, group=group)


def _se3_state_prior(group: LieGroup, read: Callable, spec: Mapping, keys: Sequence[Key]) -> Factor:
    """``read``: the mean in ``group``'s stored form (from the kit's 18 numbers)."""
    mean, sigmas = read(np.asarray(spec["mean"], float)), np.asarray(spec["sigmas"], float)
    return LieStatePrior.create(keys[0], mean, sigmas, group=group)


def _se3_velocity(group: LieGroup, spec: Mapping, keys: Sequence[Key]) -> Factor:
    measured, sigmas = np.asarray(spec["measured"], float), np.asarray(spec["sigmas"], float)
    return BodyVelocityFactor.create(keys[0], measured, sigmas, group=group)


def _same(x: NDArray) -> NDArray:
    return x


def _rotation_vector(x: NDArray) -> NDArray:
    """[t; R row-major; rest] (the kit's SE(3) state) → [t; φ; rest] (lie.SE3V's), φ = Log(R)."""
    x = np.asarray(x, float)
    return np.concatenate([x[:3], lie.SO3.log(x[3:12]), x[12:]])


def _rotation_matrix(x: NDArray) -> NDArray:
    """[t; φ; rest] → [t; R row-major; rest], R = Exp(φ): the inverse of :func:`_rotation_vector`."""
    x = np.asarray(x, float)
    return np.concatenate([x[:3], lie.SO3.exp(x[3:6]), x[6:]])


_SE3, _SE3_ACC = GroupState(lie.SE3), GroupState(lie.SE3, 2)  # the states of the se3 suite (kit v5)


@dataclass(frozen=True)
class SolverForm:
    """How steam_ref's solvers hold a state that the kit stores in more numbers than its tangent has: the solvers
    take a variable's stored size for its tangent's (``steam_ref.manifold``), and run SE(3) states on lie.SE3V's
    poses [t; φ] (the same group, tangent, Jacobians and right retraction; what ``steam-ref run`` holds), so the
    kit's [t; R; ϖ] is read into that form and each estimate written back."""

    kind: Manifold  # the solvers' kind
    read: Callable[[NDArray], NDArray]  # the kit's numbers → the solvers'
    write: Callable[[NDArray], NDArray]  # the solvers' numbers → the kit's


# The kit's kind → the solvers' form of it (a kind not listed is held as the kit stores it).
SOLVER_FORMS: dict[Manifold, SolverForm] = {
    _SE3: SolverForm(GroupState(lie.SE3V), _rotation_vector, _rotation_matrix),
    _SE3_ACC: SolverForm(GroupState(lie.SE3V, 2), _rotation_vector, _rotation_matrix),
}

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
    "se2_bearing": (_pose_bearing, (SE2_STATE, _V)),  # kit v5
    "se2_bearing_range": (_pose_bearing_range, (SE2_STATE, _V)),  # kit v5
    "se2_velocity": (_twist_reading, (SE2_STATE,)),  # kit v5
    "se2_interpolated": (_lie_interpolated, (SE2_STATE, SE2_STATE, _V)),  # kit v5
    "se3_prior": (partial(_se3_prior, lie.SE3), (_SE3, _SE3)),
    "se3_wnoj_prior": (partial(_se3_wnoj_prior, lie.SE3), (_SE3_ACC, _SE3_ACC)),
    "se3_state_prior": (partial(_se3_state_prior, lie.SE3, _same), (_SE3,)),
    "se3_velocity": (partial(_se3_velocity, lie.SE3), (_SE3,)),
}
# Factor type → its steam_ref factor on the solvers' form of its states (SOLVER_FORMS), where that differs.
SOLVER_FACTORS: dict[str, Callable[[Mapping, Sequence[Key]], Factor]] = {
    "se3_prior": partial(_se3_prior, lie.SE3V),
    "se3_wnoj_prior": partial(_se3_wnoj_prior, lie.SE3V),
    "se3_state_prior": partial(_se3_state_prior, lie.SE3V, _rotation_vector),
    "se3_velocity": partial(_se3_velocity, lie.SE3V),
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


def solver_factor(spec: Mapping) -> Factor:
    """A steam_ref factor from its spec, on the solvers' form of its states (:data:`SOLVER_FORMS`)."""
    _type(spec)
    build = SOLVER_FACTORS.get(spec["type"], FACTORS[spec["type"]][0])
    return build(spec, [key(k) for k in spec["keys"]])


def solver_values(spec: Mapping[str, Sequence[float]], specs: Iterable[Mapping]) -> Values:
    """Values from key name → vector, each key of the kind the factor specs ``specs`` give it, in the solvers' form
    (:data:`SOLVER_FORMS`)."""
    kinds = key_kinds(specs)
    given, held = {}, {}
    for name, value in spec.items():
        k = key(name)
        kind = kinds.get(k, VECTOR)
        form = SOLVER_FORMS.get(kind)
        given[k] = np.asarray(value, float) if form is None else form.read(np.asarray(value, float))
        held[k] = kind if form is None else form.kind
    return Values(given, kinds={k: m for k, m in held.items() if m is not VECTOR})


# The solvers' kind → its form.
_KIT_FORMS: dict[Manifold, SolverForm] = {form.kind: form for form in SOLVER_FORMS.values()}


def kit_value(values: Values, k: Key) -> NDArray:
    """The estimate of ``k`` in ``values`` (a solver's), in the kit's stored form."""
    form = _KIT_FORMS.get(values.kind(k))
    return np.asarray(values[k]) if form is None else form.write(np.asarray(values[k]))


def values(spec: Mapping[str, Sequence[float]], kinds: Mapping[Key, Manifold] | None = None) -> Values:
    """Values from key name → vector; ``kinds``: of the keys that are not plain vectors (:func:`key_kinds`)."""
    given = {key(k): np.asarray(v, float) for k, v in spec.items()}
    return Values(given, kinds={k: m for k, m in (kinds or {}).items() if k in given})


def ordering(names: Sequence[str], dims: Mapping[str, int]) -> Ordering:
    """An Ordering of the named variables, in the order given."""
    return Ordering(tuple(key(k) for k in names), tuple(int(dims[k]) for k in names))

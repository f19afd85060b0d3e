"""The kit's language-neutral specs (keys, factors, values) as steam_ref objects.

A key is a string: ``"x3"`` is trajectory state 3, ``"l1"`` landmark 1. A factor is a dict with a
``type``, its ``keys`` and the numbers its model needs (docs/conformance.md lists them):

    gp_prior       keys [x1, x2], dt, qc                      e = x₂ - Φ x₁      [YIB Eq. 22, 30-31]
    prior          keys [k], mean, noise                      e = θ - mean       [YIB Eq. 4]
    odometry       keys [x], measured [v, ω], noise           [YIB Eq. 32]
    velocity       keys [x], measured [v, v_lat, ω], noise    the scripts' projected velocity (forward, lateral, yaw rate)
    range          keys [x, l], measured r, noise             [YIB Eq. 33]
    bearing        keys [x, l], measured b, noise             error wrapped to [-π, π)
    bearing_range  keys [x, l], measured [b, r], noise
    interpolated   keys [x1, x2, (l)], t1, t2, tau, qc, inner (a measurement spec without keys)  [YIB Eq. 29]

where noise is ``sigma`` (a scalar), ``sigmas`` (one per error entry) or ``covariance`` (a matrix),
and a measurement may carry ``loss``: ``{"type": "huber", "k": k}`` or ``{"type": "tukey", "c": c}``.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence

import numpy as np

from ..errors import SteamError
from ..factors import (
    BearingFactor,
    BearingRangeFactor,
    Factor,
    GPPriorFactor,
    InterpolatedFactor,
    OdometryFactor,
    PriorFactor,
    RangeFactor,
    VelocityFactor,
)
from ..linear.ordering import Ordering
from ..robust import Huber, RobustLoss, Tukey
from ..variables import Key, L, Values, X

__all__ = ["key", "key_name", "factor", "values", "ordering"]

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


def _measurement(spec: Mapping, keys: Sequence[Key]) -> Factor:
    kind, loss, noise = spec["type"], _loss(spec.get("loss")), _noise(spec)
    if kind == "odometry":
        return OdometryFactor.create(keys[0], spec["measured"], noise, loss=loss)
    if kind == "velocity":
        return VelocityFactor.create(keys[0], spec["measured"], noise, loss=loss)
    if kind == "range":
        return RangeFactor.create(keys[0], keys[1], float(spec["measured"]), noise, loss=loss)
    if kind == "bearing":
        return BearingFactor.create(keys[0], keys[1], float(spec["measured"]), noise, loss=loss)
    if kind == "bearing_range":
        b, r = spec["measured"]
        return BearingRangeFactor.create(keys[0], keys[1], float(b), float(r), noise, loss=loss)
    raise SteamError(f"unknown factor type {kind!r}")


def factor(spec: Mapping) -> Factor:
    """A steam_ref factor from its spec."""
    keys = [key(k) for k in spec["keys"]]
    kind = spec["type"]
    if kind == "gp_prior":
        return GPPriorFactor.wnoa(keys[0], keys[1], float(spec["dt"]), np.asarray(spec["qc"], float))
    if kind == "prior":
        return PriorFactor.create(keys[0], np.asarray(spec["mean"], float), _noise(spec), loss=_loss(spec.get("loss")))
    if kind == "interpolated":
        stand_in = X(10**9)  # the missing state x(τ): not a variable of any graph
        inner = _measurement(spec["inner"], [stand_in, *keys[2:]])
        return InterpolatedFactor.create(
            inner,
            keys[0],
            keys[1],
            float(spec["t1"]),
            float(spec["t2"]),
            float(spec["tau"]),
            np.asarray(spec["qc"], float),
        )
    return _measurement(spec, keys)


def values(spec: Mapping[str, Sequence[float]]) -> Values:
    """Values from key name → vector."""
    return Values({key(k): np.asarray(v, float) for k, v in spec.items()})


def ordering(names: Sequence[str], dims: Mapping[str, int]) -> Ordering:
    """An Ordering of the named variables, in the order given."""
    return Ordering(tuple(key(k) for k in names), tuple(int(dims[k]) for k in names))

"""What a stream asks of every solver (:class:`OnlineSolver`), and how a forgotten past is read.  [YIB Sec. IV]

The run loop asks every solver the same questions; the solvers themselves (PB, PBVR, BTGP and the fixed-lag BTGP)
are :mod:`steam_ref.paper.solvers`'. A solver that forgets (the fixed-lag one) answers the questions about what it
forgot; the others keep the defaults of :class:`OnlineSolver`: nothing forgotten, no window. The past is read with an
explicit argument, ``past`` (:data:`PASTS`): ``"lagged"``, each forgotten variable as it left the window (what a
fixed-lag smoother reports online), or ``"smoothed"``, given all the data so far (derivations Eq. 10.5). A solver
that forgets nothing has one past, its estimate, whichever is asked; :class:`SolverView` is a solver read with one.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from numpy.typing import NDArray

from ..errors import SteamError
from ..factors import Factor
from ..variables import Key, Values, check_key, key_list

__all__ = ["PASTS", "check_past", "OnlineSolver", "SolverView"]

PASTS = ("lagged", "smoothed")  # how a forgotten variable's estimate is read: as it left the window, or given all


def check_past(past: str) -> str:
    """``past`` itself when it is one of :data:`PASTS`; a :class:`SteamError` naming it otherwise."""
    if past not in PASTS:
        raise SteamError(f"past must be one of {', '.join(map(repr, PASTS))}, got past={past!r}")
    return past


class OnlineSolver:
    """What a stream needs from a solver: the same questions of every one.

    :meth:`update`, :meth:`estimate_of`, :meth:`estimate` and the covariance queries each solver answers; the
    questions about forgetting (:meth:`forgotten`, :attr:`n_marginalized`, :attr:`peak_window`,
    :attr:`smoothing_seconds`) have the answers of a solver that forgets nothing here.
    """

    name: str = ""

    def update(self, factors: list[Factor], values: Values) -> None:
        """Add new factors and the initial estimates of new variables, then re-solve."""
        raise NotImplementedError

    def estimate_of(self, key: Key, *, past: str = "lagged") -> NDArray:
        """Current estimate of one variable; a forgotten one read as ``past`` says (:data:`PASTS`)."""
        raise NotImplementedError

    def estimate(self, *, past: str = "lagged") -> Values:
        """Current estimate of every variable; the forgotten ones read as ``past`` says (:data:`PASTS`)."""
        raise NotImplementedError

    def estimates_of(self, keys: Sequence[Key], *, past: str = "lagged") -> dict[Key, NDArray]:
        """Current estimate of each of ``keys``, as :meth:`estimate_of` reads each (a solver that forms its
        estimates on demand forms these in one call per kind); a key named twice is refused (the answer, a mapping
        by key, would hold it once)."""
        return {k: self.estimate_of(k, past=past) for k in key_list("keys", keys, distinct=True)}

    def forgotten(self) -> Sequence[Key]:
        """The variables the last update forgot (marginalized): none."""
        return ()

    @property
    def n_marginalized(self) -> int | None:
        """Variables forgotten so far (None: this solver forgets nothing)."""
        return None

    @property
    def peak_window(self) -> int | None:
        """Most variables held at once (None: this solver holds everything, it has no window)."""
        return None

    @property
    def smoothing_seconds(self) -> float | None:
        """Wall time of the backward pass behind the latest ``past="smoothed"`` query since the last update
        (None: none ran; a solver that forgets nothing needs none)."""
        return None

    def marginal_covariance(self, key: Key) -> NDArray:
        """Marginal covariance (d, d) of one variable (GTSAM's ``marginalCovariance``)."""
        return self.marginal_covariances([check_key("key", key)])[key]

    def marginal_covariances(self, keys: Sequence[Key]) -> dict[Key, NDArray]:
        """Marginal covariance of each of ``keys``."""
        raise NotImplementedError

    def joint_covariance(self, keys: Sequence[Key]) -> NDArray:
        """Joint marginal covariance of ``keys``, (Σdₖ, Σdₖ), in the order given (GTSAM's ``jointMarginalCovariance``)."""
        raise NotImplementedError

    def joint_covariances(self, groups: Sequence[Sequence[Key]]) -> list[NDArray]:
        """Joint marginal covariance of each group of keys, stacked in the order given."""
        raise NotImplementedError


@dataclass(frozen=True)
class SolverView:
    """A solver read with one choice of ``past``: what a :class:`~steam_ref.trajectory.Trajectory` queries."""

    solver: OnlineSolver
    past: str = "lagged"

    def __post_init__(self) -> None:
        check_past(self.past)

    def estimate_of(self, key: Key) -> NDArray:
        """The solver's estimate of ``key``, a forgotten one read as this view's ``past``."""
        return self.solver.estimate_of(key, past=self.past)

    def estimates_of(self, keys: Sequence[Key]) -> dict[Key, NDArray]:
        """The solver's estimate of each of ``keys``, read as this view's ``past``."""
        return self.solver.estimates_of(keys, past=self.past)

    def estimate(self) -> Values:
        """The solver's estimate of every variable, read as this view's ``past``."""
        return self.solver.estimate(past=self.past)

    def marginal_covariances(self, keys: Sequence[Key]) -> dict[Key, NDArray]:
        """The solver's marginal covariance of each of ``keys`` (``past`` does not enter)."""
        return self.solver.marginal_covariances(keys)

    def joint_covariance(self, keys: Sequence[Key]) -> NDArray:
        """The solver's joint marginal covariance of ``keys``, in the order given."""
        return self.solver.joint_covariance(keys)

    def joint_covariances(self, groups: Sequence[Sequence[Key]]) -> list[NDArray]:
        """The solver's joint marginal covariance of each group of keys."""
        return self.solver.joint_covariances(groups)

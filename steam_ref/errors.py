"""The one exception family of steam_ref.

Every check of user input raises a subclass of :class:`SteamError`, and the message names the
offending value, so a caller can catch ``steam_ref.SteamError`` and show it as it is. Each class has
one meaning:

- :class:`ShapeError`: an argument has the wrong shape, or holds NaN/inf as given;
- :class:`DataError`: a data file is missing, malformed or inconsistent;
- :class:`UnknownVariableError`: a variable is named that has no estimate;
- :class:`KindError`: a variable's kind (the space it lives in, :mod:`steam_ref.manifold`) is given two ways that
  disagree: by two factors, by a factor and the solver holding it, or by a factor and ``Values(kinds=)``;
- :class:`UnderdeterminedError`: the factors leave a variable unconstrained;
- :class:`NumericalError`: a computation on valid input overflowed to NaN/inf or lost the precision
  its answer needs (never "the iterations stopped short": that is convergence);
- :class:`ConvergenceError`: an iteration that must return a converged answer did not reach one;
- :class:`ClockError`: times compared on two clocks, or a time outside the span it must fall in
  (truth stamped in seconds queried against a trajectory's pose index, say).

Every warning is a :class:`SteamWarning`, flagging a result that is returned anyway, with the reason in it:
:class:`IllConditionedWarning` (float64 cannot resolve the answer), :class:`ConvergenceWarning`
(an iteration asked to converge stopped before its check passed), :class:`DivergenceWarning` (a stream
diverges), :class:`UncleanedDataWarning` (a named data set was read from other files than the paper's),
:class:`DegenerateMeasurementWarning` (a measurement evaluated where its Jacobian is undefined, given by a
stated convention) and :class:`WrappedTurnWarning` (an estimate turns half a turn or more between two states, which
the prior's local variable reads modulo a full turn).
"""


class SteamError(ValueError):
    """Base class of every error steam_ref raises on bad input or an ill-posed problem."""


class ShapeError(SteamError):
    """An array has the wrong shape or holds NaN/inf."""


class DataError(SteamError):
    """A data file is missing, malformed or inconsistent (unknown landmark, time going backwards...)."""


class UnknownVariableError(SteamError, KeyError):
    """A factor or query names a variable that has no estimate."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class KindError(SteamError):
    """Two sources disagree on a variable's kind (a vector, an SE(2) state...): two factors, a factor and the
    solver holding the variable, or a factor and the kind its value was given; the message names the key and both."""


class UnderdeterminedError(SteamError):
    """The information matrix is singular: some variable is not constrained by the factors.

    Its message names the variable and ends with what to do (:data:`remedy`, written here once for every place that
    raises it): most often a problem built without a prior on any state, which the GP prior and odometry alone leave
    free to slide and turn."""

    remedy = (
        "to fix it, add factors that pin it down: a PriorFactor on one state (the GP prior and odometry fix only how the "
        "trajectory moves, not where it is) and, for a landmark, a PriorFactor or readings from enough poses to fix "
        "its position"
    )

    def __str__(self) -> str:
        return f"{self.args[0]}; {self.remedy}" if self.args else self.remedy


class NumericalError(SteamError):
    """A computation gave NaN or inf (an overflowing reading, say), or lost the precision its answer needs."""


class ConvergenceError(SteamError):
    """An iteration that returns only its answer (``batch_solve``) stopped before that answer passed its
    convergence check; the message says which rule stopped it and what the check found."""


class ClockError(SteamError):
    """A time is not on the clock it is compared with, or falls outside the span it must (a query before
    the first estimated state, or after the last one where only the prior's prediction is known)."""


class SteamWarning(UserWarning):
    """Base class of every warning steam_ref gives: ``warnings.simplefilter("error", SteamWarning)`` makes them errors."""


class IllConditionedWarning(SteamWarning):
    """The information matrix is so ill-conditioned that float64 cannot resolve the answer to the tolerance asked."""


class ConvergenceWarning(SteamWarning):
    """An iteration asked to converge stopped before its check passed, and its result, returned flagged
    (``converged=False``), says why."""


class DivergenceWarning(SteamWarning):
    """A streamed estimate met a reading beyond any plausible noise, or stopped fitting what it was given
    (it diverges); the run's result records it (``RunResult.divergence``)."""


class UncleanedDataWarning(SteamWarning):
    """``load_dataset("plaza")`` found no cleaned file (``Plaza1_thrown_away_some_range.mat``, the paper's) and read
    the original Plaza1 text files instead (all 3,529 ranges, outliers included): not the paper's data."""


class DegenerateMeasurementWarning(SteamWarning):
    """A measurement was evaluated where its Jacobian is undefined, and the stated convention was used instead
    (a range with the robot exactly at the landmark: error 0 - r, Jacobian rows zero)."""


class WrappedTurnWarning(SteamWarning):
    """An estimate on a group of rigid motions turns by π or more between two consecutive states (the body twist at
    either end over their gap): a motion prior on the group reads the turn through Log(T₁⁻¹ T₂), which holds less
    than half a turn, so the estimate is one of several minima, its turn read modulo a full one (another start or
    solver may end at another). States closer in time remove it."""

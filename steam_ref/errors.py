"""The one exception family of steam_ref.

Every check of user input raises a subclass of :class:`SteamError`, and the message names the
offending value, so a caller can catch ``steam_ref.SteamError`` and show it as it is.
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


class UnderdeterminedError(SteamError):
    """The information matrix is singular: some variable is not constrained by the factors."""


class NumericalError(SteamError):
    """A computation gave NaN or inf (an overflowing reading, say), or lost the precision its answer needs."""


class IllConditionedWarning(UserWarning):
    """The information matrix is so ill-conditioned that float64 cannot resolve the answer to the tolerance asked."""


class ConvergenceWarning(UserWarning):
    """An iteration asked to converge stopped before its check passed; the result says why."""


class DivergenceWarning(UserWarning):
    """A streamed estimate met a reading beyond any plausible noise, or stopped fitting what it was given
    (it diverges); the run's result records it (``RunResult.divergence``)."""

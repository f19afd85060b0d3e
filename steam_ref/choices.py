"""What a user types, read without NumPy: the names offered as choices, the defaults a help quotes, numbers as text.

The ``steam-ref`` command builds its parser from this module alone (and the data sets' registry,
:mod:`steam_ref.datasets.registry`), so ``steam-ref --help`` and a bad argument's one-line answer load no solver,
no NumPy and no SciPy. Each list here is the one home of its names, and the module that owns what is named reads
it: ``motion.MOTION_PRIORS`` is one prior per name of :data:`MOTION_PRIOR_NAMES`; ``paper.presets.PRESETS`` and
``DEPARTURES``, ``paper.solvers.METHODS``, ``lie.gp.MODELS`` and ``conformance.gate.CONVENTION_NAMES`` are these
objects. Two tables keyed by these names keep their own keys and are checked against them by
``tests/test_choices.py``, which fails when the parser's choices and a real table disagree:
``paper.consistency.STUDIES`` (:data:`CONSISTENCY_STUDIES`) and the conformance kit's suites
(``conformance.kitio.SUITES``, :data:`CONFORMANCE_SUITES`: the kit's file format shares no code with steam_ref but
its errors, by design).

- **Numbers written as text** (a command-line value, a field of a text file): plain ASCII decimal, :data:`DECIMAL`
  (``-1.5``, ``.5``, ``2e-3``; an integer, :data:`DIGITS`), never what ``float()`` also reads: ``1_0`` (10),
  full-width ``５`` (5), ``inf``, ``nan`` or surrounding blanks (:func:`parse_decimal`; re-exported by
  :mod:`steam_ref.arguments`, which states every other rule of what the API accepts).

Imports nothing (not even steam_ref's errors): layer 0.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = [
    "CONFORMANCE_CONVENTIONS",
    "CONFORMANCE_SUITES",
    "BATCH_ORDERINGS",
    "CONSISTENCY_STUDIES",
    "DECIMAL",
    "DEPARTURES",
    "DIGITS",
    "GTSAM_RELINEARIZE_SKIP",
    "GTSAM_RELINEARIZE_THRESHOLD",
    "METHODS",
    "MOTION_PRIOR_NAMES",
    "PAPER_AMALGAMATION_ZEROS",
    "PRESETS",
    "PriorName",
    "RESIDUALS",
    "SINGER_TIME_CONSTANT",
    "parse_decimal",
    "underflowed",
]

DECIMAL = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")  # a plain decimal number
DIGITS = re.compile(r"[+-]?[0-9]+")  # a plain integer


def parse_decimal(text: str, convert: type = float) -> float | int | None:
    """``text`` read as a number by the one rule for numbers written as text (:data:`DECIMAL`, or
    :data:`DIGITS` for ``convert=int``), or None when it is not one: ``1_0`` and ``５`` are not numbers here."""
    rule = DIGITS if convert is int else DECIMAL
    return convert(text) if isinstance(text, str) and rule.fullmatch(text) else None


def underflowed(text: str, value: float | None) -> str:
    """ "" unless ``text`` writes a number other than 0 that float64 reads as ``value`` 0 ('1e-400'; None, not read as
    a number: ""); then the words saying so. A threshold, a fraction or a batch of 0 is another setting than a tiny one: a command refuses it."""
    written_zero = value != 0 or not any(c in "123456789" for c in text.lower().partition("e")[0])
    return "" if written_zero else ", which float64 cannot hold (it reads as 0)"


@dataclass(frozen=True)
class PriorName:
    """What a motion prior a user can name says of itself: ``options``, the keywords it takes beside Qc (as
    ``PaperSetup`` and the command line name them); ``what``, one line; ``dimensions``, of the space its states'
    body moves in (2: a pose [x, y, θ] or on SE(2); 3: on SE(3)), a data set's own (``DataSet.dimensions``) when the
    prior runs on it. Its constructor is ``steam_ref.motion.MOTION_PRIORS[name].make``."""

    options: tuple[str, ...]
    what: str
    dimensions: int = 2


# The motion priors by the names a user types, in the order help lists them. A new prior is a line here and its
# constructor in steam_ref/motion/table.py (docs/architecture.md, "Add a motion prior").
MOTION_PRIOR_NAMES: dict[str, PriorName] = {
    "wnoa": PriorName((), "white noise on acceleration, the paper's prior [YIB Eq. 30-31]"),
    "wnoj": PriorName((), "white noise on jerk (states with an acceleration)"),
    "singer": PriorName(("singer_time_constant",), "Singer's model (states with an acceleration)"),
    "se2": PriorName(("se2_residual",), "white noise on acceleration on SE(2) (a pose and its body twist)"),
    "se2-wnoj": PriorName((), "white noise on jerk on SE(2) (a pose, its body twist and acceleration)"),
    "se2-singer": PriorName(("singer_time_constant",), "Singer's model on SE(2) (with acceleration)"),
    "se3": PriorName((), "white noise on acceleration on SE(3), local-variable residual (Qc 6 x 6)", 3),
    "se3-simplified": PriorName((), "white noise on acceleration on SE(3), simplified residual", 3),
    "se3-wnoj": PriorName((), "white noise on jerk on SE(3) (a pose, its body twist and acceleration)", 3),
    "se3-singer": PriorName(("singer_time_constant",), "Singer's model on SE(3) (with acceleration)", 3),
}

RESIDUALS = ("local-variable", "simplified")  # the two WNOA residuals on a group in circulation (derivations §11)

SINGER_TIME_CONSTANT = 1.0  # Singer's 1/α unless a set-up says otherwise, on the model's clock (seconds, or pose steps)

PRESETS = ("synthetic", "plaza", "victoria-park")  # PaperSetup.named

# The deliberate departures from the scripts, by name: the PaperSetup fields each one changes
# (docs/experiments.md gives each one's measured effect on the Plaza run).
DEPARTURES: dict[str, dict[str, object]] = {
    "time-attachment": dict(range_attachment="time"),  # a range goes to the first pose at or after its time stamp
    "plain-heading-rate": dict(pose2_heading_rate_guess=False),  # a new state's θ̇ starts from the plain heading change
    "whole-state-relinearization": dict(relinearize_blocks=None),  # iSAM2 relinearizes the 6-vector state at once
    "landmarks-at-sighting": dict(landmarks_up_front=False),  # a landmark enters with its first range reading
}

# The presets' relaxed amalgamation (ISAM2Params.amalgamation_zeros, [AG89]): fewer, larger cliques than GTSAM's
# ISAM2 builds, for ~0.8x the CPU of a long BTGP run. Estimates move only within the wildfire threshold's tolerance
# (Plaza BTGP/1: at most 3 mm, RMSE 0.338282 → 0.338271 m; still 1.18 / 6.22 mm from the authors' saved run);
# ISAM2Params itself keeps GTSAM's 0, and so does the conformance kit (docs/experiments.md, "Relaxed amalgamation").
PAPER_AMALGAMATION_ZEROS = 0.3

GTSAM_RELINEARIZE_THRESHOLD = 0.1  # ISAM2Params' default, GTSAM's: β of [K12 Alg. 5]
GTSAM_RELINEARIZE_SKIP = 10  # ISAM2Params' default, GTSAM's relinearizeSkip

METHODS = ("btgp", "pb", "pbvr")  # a stream's solver (paper.solvers): BTGP, periodic batch, PB with AMD reordering

# the paper's names of a batch solve by its ordering [YIB Sec. IV] (`steam-ref batch --ordering`; each a name
# linear.ordering.make_ordering knows)
BATCH_ORDERINGS = {"xl": "PB", "amd": "PBVR"}

CONSISTENCY_STUDIES = ("wnoa", "se2", "se3", "se3-wnoj")  # the keys of paper.consistency.STUDIES, by model

# the conformance kit's suites, as `steam-ref conformance check --only` offers them: the kit's file format keeps its
# own list, conformance.kitio.SUITES (it shares no code with steam_ref but its errors: tests/test_architecture.py), and
# tests/test_choices.py checks the two agree
CONFORMANCE_SUITES = (
    "gp",
    "factors",
    "linear",
    "batch",
    "bayes_tree",
    "incremental",
    "fixed_lag",
    "se2",
    "se3",
    "paper",
)
# the documented alternatives `steam-ref conformance check --conventions` compares under (conformance.gate)
CONFORMANCE_CONVENTIONS = ("paper-sign", "symmetric-whitener", "signed-half-turn")  # the last: kit v5 on

"""``steam-ref fit-qc``: the maximum-likelihood diagonal Qc of a motion prior, from a data set's ground truth.

The poses of the ground truth at the data set's pose times, on the preset's GP clock (pose steps for the CMU
sets, seconds otherwise), are the data; the velocities are smoothed under the prior and Qc is the maximum of the
poses' likelihood, closed form per dimension (:func:`steam_ref.evaluate.fit_qc`, docs/derivations.md §16). It
prints the fitted diagonal with each entry's standard error and unit (:func:`~steam_ref.evaluate.fit_qc.qc_units`:
m²/s³ for x and y and rad²/s³ for θ under WNOA, per pose step on a 'pose-index' clock; ``--json``: ``qc_units``, one
per entry of ``qc_diagonal``, ``standard_error`` and ``preset_qc_diagonal``, as ``'m^2/s^3'``) beside the preset's Qc,
and the ``--qc`` that makes ``steam-ref run`` use it. A data set without ground truth is refused in one line, and so
is a 3-D set (its ground truth is on SE(3): no fit there yet) or a 3-D prior.
"""

from __future__ import annotations

import argparse
import shlex

import numpy as np

from ..errors import DataError, SteamError
from ..evaluate.fit_qc import QcFit, fit_qc, poses_needed, qc_units
from ..gp.clock import Clock
from ..motion import MOTION_PRIORS, motion_prior
from ..paper.presets import PaperSetup
from .args import check_prior_options, preset_of
from .inputs import load_with_note
from .parsers.fit_qc import check
from .streams import json_line

__all__ = ["run"]


def run(args: argparse.Namespace) -> int:
    """Fit Qc to the data set's ground truth and print it."""
    check(args)  # what is checked before anything is read (commands.main made these checks before this module loaded)
    setup = PaperSetup.named(preset_of(args))
    if args.prior is not None:
        setup = setup.replace(prior=args.prior)
    given = {name: value for name, value in {"se2_residual": args.se2_residual}.items() if value is not None}
    check_prior_options(setup.prior, given)  # an option only of the priors that take it
    setup = setup.replace(**given)
    data = load_with_note(args)
    if data.ground_truth is None:
        raise DataError(
            f"--dataset {args.dataset!r} has no ground truth: fit-qc fits Qc to the true poses of a run, and this "
            "one has none"
        )
    n = data.n_poses if args.max_poses is None else min(args.max_poses, data.n_poses)
    needed = poses_needed(setup.motion_prior())  # --max-poses' own check (>= 3) is WNOA's: a jerk prior needs more
    if args.max_poses is not None and args.max_poses < needed:
        raise SteamError(
            f"--max-poses {args.max_poses}: --prior {setup.prior} needs {needed} poses or more to be fitted"
        )
    clock = Clock.of(data.ground_truth[:n, 0], setup.clock, data.time_origin)
    options = setup.prior_options()
    fit = fit_qc(
        setup.motion_prior(),
        clock.model,
        data.ground_truth[:n, 1:4],
        refit=lambda qc: motion_prior(setup.prior, qc, **options),
    )
    names = setup.motion_prior().state_names[-setup.qc.shape[0] :]  # Qc drives the last block's rate
    flag = ",".join(f"{q:.6g}" for q in np.diag(fit.qc))
    rerun = _rerun(args, setup.prior, flag)
    if args.json:
        print(
            json_line(
                {"dataset": args.dataset, "preset": setup.name, "prior": setup.prior, **options, "poses": n}
                | {"clock": clock.describe(), "preset_qc_diagonal": np.diag(setup.qc).tolist(), "driven": list(names)}
                | fit.summary()
                | {"qc_units": list(qc_units(fit.blocks, clock))}
                | {"run": rerun}
            )
        )
        return 0
    print(_text(args.dataset, setup, n, clock, fit, names, rerun))
    return 0


def _rerun(args: argparse.Namespace, prior: str, qc: str) -> str:
    """The ``steam-ref run`` that uses the fit, on the data it was fitted to: the same set (a PATH with its --preset,
    whose GP clock the Qc is on), --data-dir and --seed when given, and --se2-residual; quoted for a shell."""
    given = {"--preset": args.preset, "--data-dir": args.data_dir, "--seed": args.seed, "--prior": prior}
    given["--se2-residual"] = args.se2_residual  # given or None, whatever the prior: the run checks it as fit-qc did
    words = ["steam-ref", "run", "--dataset", args.dataset]
    words += [w for option, value in given.items() if value is not None for w in (option, str(value))]
    return shlex.join([*words, "--qc", qc])


def _text(dataset: str, setup: PaperSetup, n: int, clock: Clock, fit: QcFit, names: tuple[str, ...], rerun: str) -> str:
    """What the command prints without --json."""
    lines = [
        f"{dataset}: {n} poses of ground truth; prior {setup.prior} ({MOTION_PRIORS[setup.prior].what})",
        f"clock: {clock.describe()}",
        (
            f"Qc by maximum likelihood (docs/derivations.md §16; velocities smoothed, {fit.rounds} round(s), "
            f"{fit.dof} degrees of freedom per dimension):"
        ),
    ]
    units = qc_units(fit.blocks, clock, superscripts=True)
    for j, name in enumerate(names):
        q, se, preset = fit.qc[j, j], fit.standard_error[j], setup.qc[j, j]
        lines.append(f"  d/dt {name:<9} {q:.6g} ± {se:.2g} {units[j]}   (preset {preset:.6g}: {q / preset:.3g} of it)")
    lines.append(f"use it: {rerun}")
    return "\n".join(lines)

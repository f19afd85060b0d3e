"""What a command makes of its parsed arguments when it runs: the data set loaded, the Qc it runs with.

The checks that need the data search, NumPy or a loader, so they are here and not in :mod:`~steam_ref.cli.args`,
which the parser reads without them.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from ..datasets import LandmarkDataset, RangeDataset, load_dataset
from ..datasets.rigid import RigidReadings
from ..errors import SteamError, UncleanedDataWarning
from .args import QC_SCALES, not_planar, seed_of

__all__ = ["load_with_note", "scaled_qc"]


def scaled_qc(preset: np.ndarray, given: list[float] | None, factor: float) -> np.ndarray:
    """Qc of a run: ``--qc`` (``given``, its diagonal; None: the ``preset``'s) times ``--qc-scale`` (``factor``);
    SteamError naming both when an entry of its diagonal is past float64, or more than :data:`QC_SCALES` away from
    the preset's either way (float64 would not resolve the prior beside the readings; the preset's times a scale
    in QC_SCALES never is)."""
    qc = preset if given is None else np.diag(given)
    with np.errstate(over="ignore"):  # refused just below, in one line
        qc = factor * qc
        ratio = np.diag(qc) / np.diag(preset)
    low, high = QC_SCALES
    if not (np.isfinite(qc).all() and np.all((low <= ratio) & (ratio <= high))):
        past = f"past float64's largest number ({np.finfo(float).max:.3g})" if not np.isfinite(qc).all() else None
        shown = ",".join(f"{v:g}" for v in np.diag(qc))
        raise SteamError(
            f"--qc {','.join(f'{v:g}' for v in given or [])} times --qc-scale {factor:g} gives Qc's diagonal "
            f"{past or shown}, beyond {low:g} to {high:g} times the preset's ({','.join(f'{v:g}' for v in np.diag(preset))}"
            "): float64 would not resolve the prior's information beside the readings; give a --qc (or --qc-scale) "
            "nearer the preset's"
        )
    return qc


def load_with_note(args: argparse.Namespace) -> RangeDataset | LandmarkDataset:
    """``--dataset`` loaded for a command whose summary says what it read: its NOTE line says uncleaned Plaza data
    (explain.data_lines), so load_dataset's UncleanedDataWarning would only repeat it."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UncleanedDataWarning)
        data = load_dataset(args.dataset, data_dir=args.data_dir, seed=seed_of(args))
    if isinstance(data, RigidReadings):  # a 3-D set: `steam-ref run` solves it (cli/rigid.py)
        raise not_planar(args.dataset)
    return data

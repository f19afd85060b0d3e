"""SLAM data sets: two dataclasses, their loaders, the synthetic generator.  [YIB Sec. IV]

- :mod:`.table`: :class:`RangeDataset`, the CMU range-only layout (GT, DR, DRp, TL, TD) and its
  checks; the conventions every source follows are in its docstring.
- :mod:`.matfile`: :func:`read_mat`, a .mat file's arrays after a walk of its structure (a
  corrupted tag would crash scipy's reader, not raise).
- :mod:`.landmarks`: :class:`LandmarkDataset`, odometry with ranges, bearings and bearing-ranges,
  landmarks surveyed or not, ground truth optional (Victoria Park); it shares the table checks.
- :mod:`.cmu`: :func:`load_cmu_mat` and :func:`load_cmu_text`, readers of the CMU files.
- :mod:`.gtsam_text`: :func:`load_gtsam_2d`, a reader of GTSAM's planar text format (ODOMETRY and
  LANDMARK rows, as ``gtsam.load2D`` reads them).
- :mod:`.textfile`: :func:`~.textfile.text_lines` and :func:`~.textfile.check_regular`, what every reader checks
  of a file before it parses a number (a regular file, not a FIFO; ASCII; its last line ended, not cut short).
- :mod:`.synthetic`: :func:`generate_synthetic`, a task like the paper's Section IV-A.
- :mod:`.sampled`: :func:`sample_from_model`, a task drawn from the estimator's own model, any motion prior
  (consistency).
- :mod:`.search`: :func:`load_dataset` by name or path, searching :func:`default_data_dirs`
  (``data_dir``, ``$STEAM_REF_DATA_DIR``, the fetched files' cache folder, gtsam's ``Data/``).
- :mod:`.registry`: the paper's files by name, each with its source, sha256 and size, and the check of a
  file found under one of those names (at every read, never trusted by name).
- :mod:`.fetch`: the paper's files by name, each with its source and sha256, fetched into the user's
  cache folder (``steam-ref data fetch``); imported on its own (it loads pooch).

Errors: a table of the wrong shape given to :class:`RangeDataset` raises :class:`ShapeError`;
bad content (NaN, pose times not increasing, unknown landmark ids) raises :class:`DataError`; the
loaders re-raise either as :class:`DataError` prefixed with the file name.

The names below load from their modules when first used (PEP 562), so that importing one light module of the
package (:mod:`.registry`, :mod:`.search`: what the command's parser reads) loads no loader, NumPy or SciPy.
"""

from typing import TYPE_CHECKING

from .._package import lazy_names

# Each public name and the module it lives in (loaded when the name is first used).
_HOMES = {
    "RangeDataset": "table",
    "LandmarkDataset": "landmarks",
    "load_gtsam_2d": "gtsam_text",
    "load_cmu_mat": "cmu",
    "load_cmu_text": "cmu",
    "read_mat": "matfile",
    "gtsam_data_dir": "search",
    "default_data_dirs": "search",
    "load_dataset": "search",
    "load_range_dataset": "search",
    "uncleaned_plaza": "search",
    "generate_synthetic": "synthetic",
    "sample_from_model": "sampled",
    "ModelSample": "sampled",
    "DATA_DIR_ENV": "search",
}


__getattr__, __dir__ = lazy_names(globals(), _HOMES)


if TYPE_CHECKING:  # what a type checker and an IDE see: the same names, imported eagerly
    from .cmu import load_cmu_mat, load_cmu_text
    from .gtsam_text import load_gtsam_2d
    from .landmarks import LandmarkDataset
    from .matfile import read_mat
    from .sampled import ModelSample, sample_from_model
    from .search import (
        DATA_DIR_ENV,
        default_data_dirs,
        gtsam_data_dir,
        load_dataset,
        load_range_dataset,
        uncleaned_plaza,
    )
    from .synthetic import generate_synthetic
    from .table import RangeDataset

__all__ = [
    "RangeDataset",
    "LandmarkDataset",
    "load_gtsam_2d",
    "load_cmu_mat",
    "load_cmu_text",
    "read_mat",
    "gtsam_data_dir",
    "default_data_dirs",
    "load_dataset",
    "load_range_dataset",
    "uncleaned_plaza",
    "generate_synthetic",
    "sample_from_model",
    "ModelSample",
    "DATA_DIR_ENV",
]

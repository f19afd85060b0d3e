"""``steam-ref fidelity``: BTGP/1 against the authors' saved runs, pose by pose, covariances included.

The data sets it runs on are those of the registry with an authors' run (``DataSet.authors_run``).
"""

from __future__ import annotations

import argparse

from ..datasets import load_range_dataset
from ..paper.fidelity import AUTHORS_RUNS, compare, find_authors_file, load_authors_run
from ..paper.online import run_online
from ..paper.options import StreamOptions
from ..paper.presets import PaperSetup
from ..plot.figures import plot_fidelity
from . import explain
from .args import preset_for
from .paths import check_output, check_outputs_apart, write_plot
from .streams import json_line

__all__ = ["run"]


def run(args: argparse.Namespace) -> int:
    """BTGP/1 with the paper's set-up against the authors' saved run of each data set."""

    check_output(args.plot, ".png", "--plot")
    check_outputs_apart({"--plot": args.plot})  # not the file stdout or stderr goes to
    distances = {}
    for name in AUTHORS_RUNS if args.dataset == "all" else [args.dataset]:
        find_authors_file(name, args.data_dir)  # before loading: gtsam's Plaza files are not the authors' data
        data = load_range_dataset(name, data_dir=args.data_dir)
        authors = load_authors_run(name, data, args.data_dir)
        setup = PaperSetup.named(preset_for(name))
        options = StreamOptions(progress=explain.progress_wanted(args.progress, args.json))
        result = run_online(data, setup, options, covariances=authors.pose_covariance is not None)
        fid, distances[name] = compare(result, authors, data.ground_truth)
        row = fid.to_dict() | {
            "total_s": round(result.total_s, 2),
            "authors_total_s": round(float(authors.step_seconds.sum()), 2),
            "data_files": explain.data_figures(data, 0)["data_files"]
            + [explain.file_entry(find_authors_file(name, args.data_dir))],
        }
        print(
            json_line(row)
            if args.json
            else explain.fidelity_text(row) + "\n" + explain.data_lines(row | {"data_note": None})
        )
    if args.plot:
        title = f"BTGP/1 against the authors' saved run, pose by pose: {', '.join(distances)}"
        where = write_plot(args, lambda name: plot_fidelity(distances, title=title, path=name))
        if where:
            print(where.strip())
    return 0

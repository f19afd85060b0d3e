"""``steam-ref reproduce``: the experiments of Fig. 3 and Fig. 4, plots and a results table."""

from __future__ import annotations

import argparse
import os

from ..errors import SteamError
from ..paper.experiments import REPRODUCED_FILES, reproduce
from . import explain
from .paths import check_out_folder, check_output, check_outputs_apart

__all__ = ["run"]


def run(args: argparse.Namespace) -> int:
    """Run the experiments, write the plots and the table, print the table."""
    check_out_folder(args.out, "--out")
    for name in REPRODUCED_FILES if os.path.isdir(args.out) else ():  # a folder there would fail the write after
        check_output(os.path.join(args.out, name), os.path.splitext(name)[1], "--out")  # the runs
        check_outputs_apart({"--out": os.path.join(args.out, name)})  # nor the file stdout goes to
    written: list[str] = []  # each file, and whether it replaced one that was there
    try:
        shown = explain.progress_wanted(args.progress, False)
        table = reproduce(
            args.out,
            quick=args.quick,
            data_dir=args.data_dir,
            jobs=args.jobs,
            progress=shown,
            wrote=lambda path, replaced: written.append(f"{path.name} (replaced)" if replaced else path.name),
        )
    except OSError as err:  # a full disk while writing the plots or the table
        raise SteamError(f"--out: cannot write {err.filename or args.out!r} ({err.strerror or err})") from None
    print(table + f"\nwritten to {os.path.abspath(args.out)}: {', '.join(written)}")
    return 0

"""``steam-ref data list`` and ``steam-ref data fetch [NAME ...]``: the paper's data by name.

``list`` shows each data set: what it is, where its files come from, the licence note, its size, and
whether it is present and where (the first folder of the search path that holds it). ``fetch`` downloads
the named sets (default: every one the authors' repository holds) into the user's cache folder,
each file checked against its sha256 (:mod:`steam_ref.datasets.fetch`); the search path finds them there.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..datasets import fetch as fetching
from ..datasets.search import data_cache_dir, uncleaned_plaza
from ..paper.progress import wanted

__all__ = ["run"]


def _size(n: int) -> str:
    return f"{n:,} B" if n else "-"


def _listed(name: str, s: fetching.DataSet, width: int) -> str:
    """The first line of a set in ``data list``: its name (in a column ``width`` wide), the size of its files
    (those found, else the registry's), and where it is, or that the file found there is not the published one;
    for an absent plaza, the original files ``--dataset plaza`` reads instead (UncleanedDataWarning)."""
    if not s.files:
        return f"{name:<{width}}  {_size(0):>12}  generated, no file"
    got = fetching.found(name)
    if got is None:
        original = uncleaned_plaza() if name == "plaza" else None
        instead = f"; --dataset plaza reads the ORIGINAL, uncleaned Plaza1 files in {original}" if original else ""
        return f"{name:<{width}}  {_size(sum(f.size for f in s.files)):>12}  absent{instead}"
    paths, differs = got
    # the searched folder that holds it (an authors' run sits in its authors/ subfolder)
    folder = paths[0].parents[len(Path(s.files[0].local).parts) - 1]
    size = _size(sum(p.stat().st_size for p in paths))
    if differs:
        return f"{name:<{width}}  {size:>12}  NOT the published file: {'; '.join(differs)}"
    return f"{name:<{width}}  {size:>12}  present  {folder}"


def run(args: argparse.Namespace) -> int:
    if args.data_command == "list":
        width = max(map(len, fetching.DATASETS))  # one column for every name, the longest included
        for name, s in fetching.DATASETS.items():
            print(_listed(name, s, width))
            print(f"{'':<{width}}  {s.what}" + (f"; from {s.source}; licence: {s.licence}" if s.files else ""))
        print(f"fetched files go to {data_cache_dir()}; fetch them with `steam-ref data fetch [NAME ...]`")
        return 0
    progress = wanted(None)  # a bar on a terminal's stderr only (not a closed one, nor a pipe)
    names = args.names or [n for n, s in fetching.DATASETS.items() if s.fetchable]
    got = fetching.fetch(names, base=args.base_url, progress=progress)  # every name checked before any download
    for name, paths in got.items():
        for p in paths:
            print(f"{name}: {p} (sha256 {fetching.file_digest(p)[:12]}, verified)")
    return 0

"""How long `import steam_ref` and `steam-ref --version` take, net of a bare interpreter's start.

Each command runs in a fresh process, alternating, ``--repeat`` times (default 5); the medians are
printed as one JSON line, and a bar chart is written to benchmarks/out/import_time.png. Targets (issue
18, the 2-core machine): ``import steam_ref`` < 0.25 s, ``steam-ref --version`` < 0.35 s, both net.

    python benchmarks/import_time.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

OUT = Path(__file__).resolve().parent / "out"

COMMANDS = {
    "bare_interpreter": [sys.executable, "-c", "pass"],
    "import_steam_ref": [sys.executable, "-c", "import steam_ref"],
    "import_and_use_bayes_tree": [sys.executable, "-c", "import steam_ref; steam_ref.IncrementalSolver"],
    "steam_ref_version": [sys.executable, "-c", "from steam_ref.cli import main; main(['--version'])"],
}


def wall(argv: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(argv, check=True, capture_output=True)
    return time.perf_counter() - start


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=5)
    a = p.parse_args(argv)
    times: dict[str, list[float]] = {name: [] for name in COMMANDS}
    for _ in range(a.repeat):
        for name, cmd in COMMANDS.items():  # alternating, so drift on a shared machine hits all alike
            times[name].append(wall(cmd))
    medians = {name: statistics.median(t) for name, t in times.items()}
    bare = medians["bare_interpreter"]
    row = {"repeat": a.repeat, "bare_interpreter_s": round(bare, 4)} | {
        f"{name}_net_s": round(m - bare, 4) for name, m in medians.items() if name != "bare_interpreter"
    }
    row["targets_met"] = row["import_steam_ref_net_s"] < 0.25 and row["steam_ref_version_net_s"] < 0.35
    print(json.dumps(row))

    import matplotlib as mpl

    mpl.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3), layout="constrained")
    names = [n for n in COMMANDS if n != "bare_interpreter"]
    ax.barh(names, [medians[n] - bare for n in names])
    ax.axvline(0.25, ls="--", c="k", lw=0.8)
    ax.set(xlabel="seconds, net of a bare interpreter (median)", title="steam_ref import time")
    OUT.mkdir(exist_ok=True)
    fig.savefig(OUT / "import_time.png", dpi=120)
    print(f"# plot: {OUT / 'import_time.png'}", file=sys.stderr)


if __name__ == "__main__":
    main()

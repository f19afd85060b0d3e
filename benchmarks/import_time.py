"""How long `import steam_ref`, `steam-ref --version`, `steam-ref --help` and a bad argument's answer take, net of
a bare interpreter's start.

Each command runs in a fresh process, alternating, ``--repeat`` times (default 5); the medians are
printed as one JSON line, and a bar chart is written to benchmarks/out/import_time.png. Targets (the 2-core
machine), all net: ``import steam_ref`` < 0.25 s, ``steam-ref --version`` < 0.35 s, ``steam-ref --help`` and a bad
argument's one-line answer (``steam-ref run --dataset nonsense``, exit code 2) < 0.35 s: parsing loads no solver.

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
    "steam_ref_help": [sys.executable, "-m", "steam_ref", "--help"],
    "steam_ref_bad_argument": [sys.executable, "-m", "steam_ref", "run", "--dataset", "nonsense"],
}
EXIT_CODES = {"steam_ref_bad_argument": 2}  # the one-line refusal; every other command exits 0
TARGETS = {"import_steam_ref": 0.25, "steam_ref_version": 0.35, "steam_ref_help": 0.35, "steam_ref_bad_argument": 0.35}


def wall(argv: list[str], code: int = 0) -> float:
    """Seconds ``argv`` takes in a fresh process; RuntimeError unless it exits with ``code``."""
    start = time.perf_counter()
    done = subprocess.run(argv, capture_output=True)
    took = time.perf_counter() - start
    if done.returncode != code:
        raise RuntimeError(f"{argv} exited {done.returncode}, not {code}: {done.stderr.decode()[-300:]}")
    return took


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=5)
    a = p.parse_args(argv)
    times: dict[str, list[float]] = {name: [] for name in COMMANDS}
    for _ in range(a.repeat):
        for name, cmd in COMMANDS.items():  # alternating, so drift on a shared machine hits all alike
            times[name].append(wall(cmd, EXIT_CODES.get(name, 0)))
    medians = {name: statistics.median(t) for name, t in times.items()}
    bare = medians["bare_interpreter"]
    row = {"repeat": a.repeat, "bare_interpreter_s": round(bare, 4)} | {
        f"{name}_net_s": round(m - bare, 4) for name, m in medians.items() if name != "bare_interpreter"
    }
    row["targets_met"] = all(row[f"{name}_net_s"] < target for name, target in TARGETS.items())
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

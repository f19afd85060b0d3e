"""The README says what runs: its code example executes and gives what it claims, and its test
command is the one `.ci/run` runs."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README, flags=re.S)


def test_readme_example_runs_and_its_two_solvers_agree():
    """The example's batch Gauss-Newton converges; the Bayes tree's estimate after its one update
    has every variable of the graph and is one Gauss-Newton step from ``initial`` (the oracle: a
    batch solve with one iteration), which lands within 1e-3 of the converged batch optimum."""
    (block,) = _python_blocks()
    scope: dict = {"__name__": "readme_example"}
    exec(compile(block, "README.md (The common case in code)", "exec"), scope)
    sr, graph, initial = scope["sr"], scope["graph"], scope["initial"]
    result, estimate = scope["result"], scope["estimate"]
    assert result.converged, result.reason
    np.testing.assert_allclose(scope["last"], result.marginal_covariances([sr.X(49)])[sr.X(49)], rtol=1e-12)
    assert scope["last"].shape == (6, 6)
    assert set(estimate.keys()) == set(graph.keys()) == set(initial.keys())
    one_step = sr.gauss_newton(graph, initial, max_iterations=1).values
    for key in graph.keys():
        np.testing.assert_allclose(estimate[key], one_step[key], rtol=1e-8, atol=1e-10)
        np.testing.assert_allclose(estimate[key], result.values[key], atol=1e-3)


def test_readme_test_command_is_the_one_ci_runs():
    commands = re.findall(r"^    (.*pytest.*)$", README, flags=re.M)
    assert len(commands) == 1, commands
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert commands[0] in ci, f"README's {commands[0]!r} is not a line of .ci/run"


def _more_commands() -> list[tuple[str, str]]:
    """The rows of the "More commands" table: (what, command)."""
    section = README.split("## More commands", 1)[1].split("\n## ", 1)[0]
    rows = re.findall(r"^\| (.*) \| (`.*`) \|$", section, flags=re.M)
    assert len(rows) > 20, "the More commands table was not found"
    return rows


def test_the_more_commands_rows_write_and_read_distinct_folders():
    """A folder one row writes figures or a kit into is never the folder another row checks as kit results
    (reproduce wrote to results/ and two rows later `conformance check results/` read it)."""
    written: dict[str, str] = {}  # folder -> the command writing it
    checked: dict[str, str] = {}
    for _, command in _more_commands():
        for folder in re.findall(r"(?:--out|conformance export) (\S+?)/?`", command):
            written[folder] = command
        for folder in re.findall(r"conformance check (\S+?)/? ", command + " "):
            checked[folder] = command
    assert written and checked
    for folder, command in checked.items():
        assert folder not in written or written[folder] == command, (folder, command, written[folder])


LONG = ("steam-ref fidelity", "steam-ref reproduce [", "--dataset victoria-park", "--seeds 200")


def test_the_long_rows_say_how_long_they_take():
    """Every row that runs for minutes (fidelity, all of Plaza, Victoria Park, reproduce, 200 seeds) says
    about how long, and on what machine."""
    for what, command in _more_commands():
        all_of_plaza = re.search(r"steam-ref run --dataset plaza (?!.*--(skip|max-poses))", command)
        if any(k in command for k in LONG) or all_of_plaza:
            assert re.search(r"(about|under) [^|]*\bon 2 cores", what), what

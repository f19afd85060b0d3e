"""The figures the commands draw show what the command ran and printed: the poses a run covered (not the whole
data set), the RMSE it printed, the paper's figure it reproduces; and ``reproduce`` writes each file whole.

Each figure is caught as it is saved (the plot module's own ``_save``, wrapped), and its lines are held to the data
set read here, apart from the command, and to the numbers the command printed.  [YIB Sec. IV, Fig. 1-4]
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from cli_runs import runner

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")

from matplotlib.figure import Figure  # noqa: E402

import steam_ref.plot.figures as figures  # noqa: E402
from steam_ref.datasets import generate_synthetic  # noqa: E402
from steam_ref.paper.experiments import reproduce  # noqa: E402
from steam_ref.paper.presets import PaperSetup  # noqa: E402

_run = runner()


@pytest.fixture
def drawn(monkeypatch) -> list:
    """The axes of every figure the plot module saves, in order."""
    caught: list = []
    save = figures._save

    def catching(axes, path):
        caught.append(axes)
        return save(axes, path)

    monkeypatch.setattr(figures, "_save", catching)
    return caught


def _line(ax, label: str) -> np.ndarray:
    (found,) = [ln for ln in ax.lines if ln.get_label() == label]
    return np.asarray(found.get_xydata())


def _printed_rmse(out: str) -> str:
    return re.search(r"RMSE ([0-9.]+) m over", out).group(1)


def test_run_of_a_prefix_draws_the_truth_and_dead_reckoning_of_that_prefix_only(capsys, small_mat, tmp_path, drawn):
    """--max-poses 25 of 61: the truth and dead reckoning drawn were all 61 poses (the figure spread over ground the
    run never reached, unlike the RMSE printed over 25); the title says the prefix and the RMSE printed."""
    path, data = small_mat
    plot = tmp_path / "run.png"
    code, out, err = _run(capsys, "run", "--dataset", path, "--preset", "synthetic", "--max-poses", 25, "--plot", plot)
    assert code == 0, err
    (ax,) = drawn
    np.testing.assert_array_equal(_line(ax, "ground truth"), data.ground_truth[:25, 1:3])
    np.testing.assert_array_equal(_line(ax, "dead reckoning"), data.dead_reckoning[:25, 1:3])
    estimate = _line(ax, "BTGP estimate")
    rmse = np.sqrt(np.mean(np.sum((estimate - data.ground_truth[:25, 1:3]) ** 2, axis=1)))
    printed = _printed_rmse(out)
    assert abs(float(printed) - rmse) < 1e-6  # what is drawn is what was scored
    assert ax.get_title() == f"BTGP/1 on {path} (first 25 of {data.n_poses} poses): position RMSE {printed} m"


@pytest.mark.parametrize(("ordering", "name"), [("xl", "PB"), ("amd", "PBVR")])
def test_batch_figure_names_the_method_and_its_rmse_and_draws_the_estimated_landmarks(
    capsys, small_mat, tmp_path, drawn, ordering, name
):
    """The title was "batch on DATA": neither PB nor PBVR, nor the score; the estimated landmarks were not drawn."""
    path, data = small_mat
    argv = ["batch", "--dataset", path, "--preset", "synthetic", "--ordering", ordering, "--plot", tmp_path / "b.png"]
    code, out, err = _run(capsys, *argv)
    assert code == 0, err
    (ax,) = drawn
    assert ax.get_title() == f"batch {name} on {path}: position RMSE {_printed_rmse(out)} m"
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == [f"{name} estimate", "ground truth", "landmarks (true)", "landmarks (estimated)"]
    marks = _line(ax, "landmarks (estimated)")
    assert len(marks) == len(data.landmarks)  # every landmark is seen in the small task
    # each estimate beside its true landmark (range-only SLAM on 61 poses: within a metre here)
    nearest = np.min(np.linalg.norm(marks[:, None] - data.landmarks[None, :, 1:3], axis=2), axis=1)
    assert np.all(nearest < 1.0), nearest


def test_consistency_figure_says_what_it_shows(capsys, tmp_path, drawn):
    code, _, err = _run(
        capsys, "consistency", "--seeds", 2, "--steps", 12, "--landmarks", 3, "--plot", tmp_path / "c.png"
    )
    assert code == 0, err
    (axes,) = drawn
    assert axes[0, 0].get_title() == "ANEES on synthetic tasks (wnoa prior), 2 runs: 95 % band shaded"


@pytest.fixture(scope="module")
def small():
    return generate_synthetic(n_steps=45, n_landmarks=10, seed=5, range_sigma=0.2)


def test_reproduce_titles_each_figure_by_the_papers_figure_and_reports_what_it_wrote(small, tmp_path):
    saved: dict[str, Figure] = {}
    original = Figure.savefig

    def keep(fig, name, *args, **kwargs):
        saved[Path(name).name.removesuffix(".png").rpartition(".")[2]] = fig  # fig3, even as ".123.ab12.fig3.png"
        return original(fig, name, *args, **kwargs)

    (tmp_path / "results.md").write_text("the user's own notes\n")
    wrote: list[tuple[str, bool]] = []
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(Figure, "savefig", keep)
        reproduce(
            tmp_path,
            progress=False,
            data_sets=[("small", small, PaperSetup.synthetic())],
            wrote=lambda path, replaced: wrote.append((path.name, replaced)),
        )
    assert wrote == [
        ("fig3.png", False),
        ("fig3_trajectory.png", False),
        ("runs.jsonl", False),
        ("results.md", True),  # the user's file was there: the caller is told it was replaced
    ]
    assert saved["fig3"]._suptitle.get_text() == "Fig. 3 of the paper reproduced: small"
    upper, lower, _, total = saved["fig3"].axes  # the paper's two left graphs, then its right panels
    assert upper.get_title() == "small: computation time per step" and upper.get_ylabel() == "time per step (s)"
    assert lower.get_title() == "small: cumulative computation time"
    drawn = {ln.get_label(): ln.get_color() for ln in upper.lines}  # the same runs in the same colours, named below
    assert drawn == {ln.get_label(): ln.get_color() for ln in lower.lines} and len(drawn) == len(
        lower.get_legend().texts
    )
    assert total.get_title() == "small: total computation time" and total.get_ylabel() == "total computation time (s)"
    trajectory = saved["fig3_trajectory"].axes[0]
    assert trajectory.get_title().startswith("Fig. 1 of the paper reproduced: small\nBTGP/1, position RMSE ")
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary left


def test_reproduce_interrupted_while_drawing_leaves_the_figure_that_was_there(small, tmp_path):
    """The figures were written in place: an interrupt mid-write left a half-written PNG where the user's was."""
    before = b"\x89PNG the figure of an earlier run"
    (tmp_path / "fig3.png").write_bytes(before)
    original = Figure.savefig

    def interrupted(fig, name, *args, **kwargs):
        original(fig, name, *args, **kwargs)
        with open(name, "r+b") as f:  # half of it on disk, then Ctrl-C
            f.truncate(f.seek(0, 2) // 2)
        raise KeyboardInterrupt

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(Figure, "savefig", interrupted)
        with pytest.raises(KeyboardInterrupt):
            reproduce(tmp_path, progress=False, data_sets=[("small", small, PaperSetup.synthetic())])
    assert (tmp_path / "fig3.png").read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig3.png"]

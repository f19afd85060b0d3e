"""steam_ref.plot, the one home of every figure: each draws the data it is given, on the axes it is
given, and saves a PNG when asked.  The Bayes tree toy is the one of test_bayes_tree_symbolic.py:

            [d e f]            root
               |
            [c : d]
            /     \\
       [a : c]   [b : c]
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.colors import to_rgba  # noqa: E402

from steam_ref import plot  # noqa: E402
from steam_ref.bayes_tree.symbolic import CliqueTree, build_cliques  # noqa: E402
from steam_ref.errors import ShapeError  # noqa: E402

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
TOY = [("a", "c"), ("b", "c"), ("c", "d"), ("d", "e"), ("d", "f"), ("e", "f")]


def toy_tree() -> CliqueTree:
    tree: CliqueTree = CliqueTree()
    cliques = build_cliques(list("abcdef"), TOY)
    tree.insert_eliminated(cliques, [c.parent for c in cliques])
    return tree


def line(ax, label: str) -> np.ndarray:
    """(n, 2) data of the one line labelled ``label``."""
    (found,) = [ln for ln in ax.lines if ln.get_label() == label]
    return np.asarray(found.get_xydata())


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


# --- imports ----------------------------------------------------------------------------------


def test_importing_steam_ref_does_not_import_matplotlib():
    code = (
        "import sys, steam_ref, steam_ref.plot, steam_ref.paper.experiments, steam_ref.cli.commands; "
        "assert 'matplotlib' not in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


@pytest.mark.parametrize("module", ["__init__", "figures", "base", "tree"])
def test_plot_imports_nothing_from_steam_ref_at_run_time(module):
    """Only under TYPE_CHECKING may the plot modules name steam_ref's types: they take plain data. Their
    run-time imports are the exceptions (steam_ref.errors, which imports nothing), so a bad array raises a
    SteamError, and each other (base's helpers; __init__ re-exports figures and tree)."""
    tree = ast.parse((Path(plot.__file__).parent / f"{module}.py").read_text())
    type_only = {
        id(n)
        for node in ast.walk(tree)
        if isinstance(node, ast.If) and getattr(node.test, "id", "") == "TYPE_CHECKING"
        for n in ast.walk(node)
    }
    runtime = [
        node.module
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom)
        and id(node) not in type_only
        and (node.level > 0 or (node.module or "").startswith("steam_ref"))
    ]
    assert set(runtime) <= {"errors", "base", "figures", "tree"}
    assert module == "__init__" or "errors" in runtime


# --- a run ------------------------------------------------------------------------------------


def test_plot_trajectory_draws_the_given_arrays(rng):
    truth, estimate, dr = (rng.normal(size=(7, 2)) for _ in range(3))
    marks, marks_est = rng.normal(size=(3, 2)), {4: rng.normal(size=2), 9: rng.normal(size=2)}
    ax = plot.plot_trajectory(
        truth,
        estimate,
        landmarks_true=marks,
        landmarks_estimated=marks_est,
        dead_reckoning=dr,
        estimate_label="BTGP estimate",
        title="t",
    )
    np.testing.assert_array_equal(line(ax, "ground truth"), truth)
    np.testing.assert_array_equal(line(ax, "BTGP estimate"), estimate)
    np.testing.assert_array_equal(line(ax, "dead reckoning"), dr)
    np.testing.assert_array_equal(line(ax, "landmarks (true)"), marks)
    np.testing.assert_array_equal(line(ax, "landmarks (estimated)"), np.array([marks_est[4], marks_est[9]]))
    assert ax.get_title() == "t"


def test_plot_trajectory_draws_only_what_it_is_given(rng):
    _fig, ax = plt.subplots()
    out = plot.plot_trajectory(None, rng.normal(size=(5, 2)), landmarks_estimated={}, ax=ax)
    assert out is ax
    assert [ln.get_label() for ln in ax.lines] == ["estimate"]


def test_plot_timing_draws_each_runs_cumulative_time(rng):
    runs = {
        "PB/1": SimpleNamespace(cumulative_s=np.cumsum(rng.uniform(0.1, 1, 6)), completed=False),
        "BTGP/1": SimpleNamespace(cumulative_s=np.cumsum(rng.uniform(0.1, 1, 9)), completed=True),
    }
    ax = plot.plot_timing(runs, title="data: computation time")
    np.testing.assert_array_equal(line(ax, "PB/1 (budget)"), np.column_stack([np.arange(6), runs["PB/1"].cumulative_s]))
    np.testing.assert_array_equal(line(ax, "BTGP/1"), np.column_stack([np.arange(9), runs["BTGP/1"].cumulative_s]))
    assert ax.get_yscale() == "log"


def test_plot_timing_per_step_draws_each_steps_own_time_and_leaves_an_idle_step_a_gap(rng):
    """The paper's upper left graph (Fig. 3/4): each step's own time, the differences of the cumulative times
    (the first step's from 0); a step that took no time (no reading, no update) is a gap on the log axis."""
    own = rng.uniform(0.1, 1, 8)
    own[3:5] = 0.0  # two idle steps: the 'gap' of the paper's Fig. 4
    runs = {"BTGP/1": SimpleNamespace(cumulative_s=np.cumsum(own), completed=True)}
    ax = plot.plot_timing(runs, per_step=True)
    drawn = line(ax, "BTGP/1")
    np.testing.assert_array_equal(drawn[:, 0], np.arange(8))
    busy = own > 0
    np.testing.assert_allclose(drawn[busy, 1], own[busy], rtol=1e-12)
    assert np.isnan(drawn[~busy, 1]).all()
    assert ax.get_ylabel() == "time per step (s)" and ax.get_yscale() == "log"


def test_plot_timing_tags_only_runs_cut_by_their_budget(rng):
    """reproduce --quick runs stop at the prefix they were given: that is not a budget (every run was tagged)."""
    cumulative = np.cumsum(rng.uniform(0.1, 1, 5))
    prefix = SimpleNamespace(max_poses=6)
    runs = {
        "BTGP/1": SimpleNamespace(cumulative_s=cumulative, completed=False, n_steps_processed=6, options=prefix),
        "PB/1": SimpleNamespace(cumulative_s=cumulative, completed=False, n_steps_processed=3, options=prefix),
    }
    ax = plot.plot_timing(runs)
    assert [ln.get_label() for ln in ax.lines] == ["BTGP/1", "PB/1 (budget)"]


def test_the_reference_is_drawn_over_the_estimate_and_true_landmarks_stand_out(rng):
    truth = rng.normal(size=(7, 2))
    ax = plot.plot_trajectory(
        truth, truth + 1e-3, landmarks_true=rng.normal(size=(2, 2)), landmarks_estimated=rng.normal(size=(2, 2))
    )
    z = {ln.get_label(): ln.get_zorder() for ln in ax.lines}
    assert z["ground truth"] > z["estimate"]  # the truth is not hidden under an estimate that lies on it
    colours = {ln.get_label(): to_rgba(ln.get_color()) for ln in ax.lines}
    assert colours["landmarks (true)"] != colours["ground truth"]
    assert colours["landmarks (true)"] != colours["landmarks (estimated)"]


def test_plot_interpolation_tradeoff_plots_the_values_it_was_given(rng):
    skips = [10, 1, 3]  # unsorted: drawn in increasing skip
    with_, without = (
        {k: SimpleNamespace(rmse_m=rng.uniform(), total_s=rng.uniform(1, 9)) for k in skips} for _ in range(2)
    )
    rmse_ax, time_ax = plot.plot_interpolation_tradeoff(with_, without, name="plaza")
    for runs, label in ((with_, "with interpolation"), (without, "without interpolation")):
        ks = sorted(runs)
        np.testing.assert_array_equal(line(rmse_ax, label), [[k, runs[k].rmse_m] for k in ks])
        np.testing.assert_array_equal(line(time_ax, label), [[k, runs[k].total_s] for k in ks])
    assert rmse_ax.get_title() == "plaza: RMSE"


# --- the Bayes tree ---------------------------------------------------------------------------


def test_tree_layout_puts_parents_above_their_childrens_middle():
    tree = toy_tree()
    pos = plot.tree_layout(tree)
    assert set(pos) == set(tree.cliques)
    for c, kids in tree.children.items():
        for k in kids:
            assert pos[c][1] == pos[k][1] + 1.0
        if kids:
            assert pos[c][0] == pytest.approx(np.mean([pos[k][0] for k in kids]), abs=1e-12)
    leaves = [pos[c][0] for c, kids in tree.children.items() if not kids]
    assert sorted(leaves) == [0.0, 1.0]
    assert [pos[r][1] for r in tree.roots] == [0.0]


def test_draw_tree_puts_one_box_per_clique_labelled_frontals_separator():
    tree = toy_tree()
    ax = plot.draw_tree(tree, title="toy")
    assert sorted(t.get_text() for t in ax.texts) == sorted(["d e f", "c : d", "a : c", "b : c"])
    pos = plot.tree_layout(tree)
    for t in ax.texts:
        (c,) = [c for c, cl in tree.cliques.items() if t.get_text().split(" : ")[0] == " ".join(cl.frontals)]
        assert t.get_position() == pytest.approx(pos[c])
    assert len(ax.lines) == len(tree) - 1  # one link per non-root clique


def test_snapshot_keeps_the_tree_as_it_was():
    tree = toy_tree()
    before = tree.snapshot()
    tree.remove_top([tree.frontal_of["a"]])
    assert before.problems() == []
    assert len(before) == 4 and len(tree) == 1
    assert plot.tree_layout(before) == plot.tree_layout(toy_tree())


def test_draw_update_colours_removed_new_and_orphan_cliques():
    tree = toy_tree()
    before = tree.snapshot()
    a, b, c, root = (tree.frontal_of[v] for v in "abcd")
    report = SimpleNamespace(step=3, removed_cliques=[a, c, root], orphans=[b], new_cliques=[root])
    left, right = plot.draw_update(before, tree, report)
    facecolour = {t.get_text(): t.get_bbox_patch().get_facecolor() for t in left.texts}
    edgecolour = {t.get_text(): t.get_bbox_patch().get_edgecolor() for t in left.texts}
    for label in ("a : c", "c : d", "d e f"):
        assert facecolour[label] == to_rgba("#e45756")
    assert facecolour["b : c"] != to_rgba("#e45756") and edgecolour["b : c"] == to_rgba("#4c78a8")
    new = {t.get_text() for t in right.texts if t.get_bbox_patch().get_facecolor() == to_rgba("#f58518")}
    assert new == {"d e f"}
    assert left.get_title().startswith("before update 3")


def test_draw_spy_shows_the_pattern_of_R_and_highlights_rows(rng):
    R = np.triu(rng.normal(size=(5, 5)))
    R[0, 3] = R[1, 4] = 0.0
    keys, dims = ("x0", "x1", "l0"), (2, 2, 1)
    ordering = SimpleNamespace(
        keys=keys,
        dims=dims,
        offsets=np.array([0, 2, 4]),
        offset_of=dict(zip(keys, (0, 2, 4), strict=True)),
        position={k: i for i, k in enumerate(keys)},
    )
    tree = SimpleNamespace(to_dense=lambda: (R, None, ordering))
    ax = plot.draw_spy(tree, highlight=["x1"])
    (marks,) = ax.lines  # spy with markers: one marker at (column, row) of each nonzero
    drawn = {(int(y), int(x)) for x, y in marks.get_xydata()}
    assert drawn == set(zip(*np.nonzero(np.abs(R) > 1e-12), strict=True))
    (band,) = ax.patches
    ys = band.get_path().transformed(band.get_patch_transform()).vertices[:, 1]  # y in data units
    assert (ys.min(), ys.max()) == (1.5, 3.5)  # rows 2 and 3, x1's
    assert [t.get_text() for t in ax.get_xticklabels()] == list(keys)


def test_plot_anees_labels_its_log_axis_with_plain_numbers():
    """A reader of an ANEES near 3 sees 2, 3, 4 on the axis, not 2×10⁰."""
    per_pose = {"btgp/1": {"pose": np.linspace(1.5, 9.0, 30), "velocity": np.linspace(2.0, 5.0, 30)}}
    axes = plot.plot_anees(per_pose, {"pose": (2.2, 3.9), "velocity": (2.2, 3.9)}, n_runs=24)
    for ax in axes[:, 0]:
        ax.figure.canvas.draw()
        labels = [t.get_text() for t in ax.yaxis.get_ticklabels(which="both") if t.get_text()]
        assert {"2", "3", "10"} <= set(labels) and not any("times" in s or "^" in s for s in labels), labels


# --- saving -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "draw",
    [
        lambda path: plot.plot_trajectory(np.zeros((3, 2)), np.ones((3, 2)), path=path),
        lambda path: plot.plot_timing({"BTGP/1": SimpleNamespace(cumulative_s=[1.0, 2.0], completed=True)}, path=path),
        lambda path: plot.plot_interpolation_tradeoff({1: SimpleNamespace(rmse_m=0.1, total_s=2.0)}, path=path),
        lambda path: plot.draw_tree(toy_tree(), path=path),
        lambda path: plot.plot_matrix(np.eye(4) + 0.1, path=path),
        lambda path: plot.plot_state_samples(np.arange(3.0), np.ones((2, 3, 4)), path=path),
    ],
    ids=["trajectory", "timing", "tradeoff", "tree", "matrix", "samples"],
)
def test_saving_writes_a_png_and_leaves_no_figure_open(tmp_path, draw):
    path = tmp_path / "figure.png"
    open_before = plt.get_fignums()
    draw(str(path))
    assert path.read_bytes()[:8] == PNG_SIGNATURE
    assert plt.get_fignums() == open_before


def test_saving_given_axes_closes_their_figure(tmp_path):
    fig, ax = plt.subplots()
    plot.plot_trajectory(np.zeros((3, 2)), np.ones((3, 2)), ax=ax, path=str(tmp_path / "t.png"))
    assert fig.number not in plt.get_fignums()
    assert (tmp_path / "t.png").read_bytes()[:8] == PNG_SIGNATURE


# --- what a reader needs to read a figure -----------------------------------------------------


def test_plot_trajectory_refuses_a_dead_reckoning_or_truth_beyond_the_estimates_poses(rng):
    """A run of a data set's first poses beside the whole set's dead reckoning or truth: the figure spread over
    ground the run never reached (the axes fit the longer curve), with nothing saying so."""
    estimate = rng.normal(size=(5, 2))
    with pytest.raises(ShapeError, match="dead_reckoning must have the estimate's 5 poses, got 9"):
        plot.plot_trajectory(None, estimate, dead_reckoning=rng.normal(size=(9, 2)))
    with pytest.raises(ShapeError, match="truth_xy must have at most the estimate's 5 poses, got 9"):
        plot.plot_trajectory(rng.normal(size=(9, 2)), estimate)
    ax = plot.plot_trajectory(estimate[::2], estimate, truth_label="batch optimum")  # a reference at states only
    np.testing.assert_array_equal(line(ax, "batch optimum"), estimate[::2])


def test_plot_anees_writes_ticks_below_one_as_plain_numbers_and_keeps_its_legend_off_the_curves():
    """An ANEES of 0.6 (an underconfident estimator) read '6e-01'; the legend sat over the curves it names."""
    low = np.geomspace(0.5, 3.0, 30)
    per_pose = {name: {"pose": low * (1 + 0.1 * k)} for k, name in enumerate(["a", "b", "c", "d", "e", "f"])}
    axes = plot.plot_anees(per_pose, {"pose": (1.7, 4.7)}, n_runs=10, title="ANEES on the task")
    ax = axes[0, 0]
    ax.figure.canvas.draw()
    labels = [t.get_text() for t in ax.yaxis.get_ticklabels(which="both") if t.get_text()]
    assert "0.6" in labels and not any("e" in s for s in labels), labels
    legend = ax.get_legend()
    assert [t.get_text() for t in legend.get_texts()][1:] == list(per_pose)
    renderer = ax.figure.canvas.get_renderer()
    assert legend.get_window_extent(renderer).x0 >= ax.get_window_extent(renderer).x1  # beside the panel
    assert ax.get_title() == "ANEES on the task"


def test_plot_fidelity_names_its_tolerance_line_and_takes_a_title(rng):
    """The dashed line's legend read '20 mm': a reader could not tell it from a data set."""
    d = rng.uniform(0, 0.004, 50)
    ax = plot.plot_fidelity({"paper-synthetic": d}, tolerance_m=0.02, title="BTGP/1 against the authors' run")
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["paper-synthetic", "tolerance 20 mm"]
    np.testing.assert_allclose(line(ax, "paper-synthetic")[:, 1], 1000 * d)
    assert ax.get_title() == "BTGP/1 against the authors' run"


def test_plot_interpolation_tradeoff_ticks_the_skips_run_and_names_total_time():
    """Its x axis read 2.5, 7.5, 12.5 time steps (never run); its time panel was titled as the timing panel."""
    runs = {k: SimpleNamespace(rmse_m=0.1 * k, total_s=10.0 / k) for k in (1, 2, 3, 5, 10, 20)}
    rmse_ax, time_ax = plot.plot_interpolation_tradeoff(runs, runs, name="plaza")
    for ax in (rmse_ax, time_ax):
        assert list(ax.get_xticks()) == [1, 2, 3, 5, 10, 20]
    assert time_ax.get_title() == "plaza: total computation time"
    assert time_ax.get_ylabel() == "total computation time (s)" and rmse_ax.get_ylabel() == "position RMSE (m)"

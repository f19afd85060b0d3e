"""The Bayes tree in GTSAM's words: ``dot()`` and ``UpdateReport.tree_nnz`` against GTSAM 4.3.

The oracle is GTSAM itself, on problems where both eliminate in the same order: a given ordering
(``GaussianFactorGraph.eliminateMultifrontal``), and an iSAM2 stream where GTSAM is told steam_ref's
order of the re-eliminated variables through ``constrainedKeys`` (one group per variable). The dot
text must then be equal character for character where no clique has two children (GTSAM's child
order comes from its junction tree), and equal as a set of lines otherwise; the nnz always.
"""

from __future__ import annotations

import numpy as np
import pytest
from requirements import optional_import

from steam_ref.bayes_tree import BayesTree, IncrementalSolver
from steam_ref.bayes_tree.dot import clique_nnz, gtsam_key, tree_dot, tree_nnz
from steam_ref.cli import main
from steam_ref.conformance import spec
from steam_ref.conformance.cases.problems import BEACONS, BUSHY, BUSHY_ORDER, ORDERINGS, TRAJECTORY
from steam_ref.factors import GPPriorFactor, PriorFactor, RangeFactor
from steam_ref.linear.system import linearize
from steam_ref.variables import L, X

QC = np.diag([0.5, 0.2, 0.1])


def one_child_each(tree) -> bool:
    return all(len(ch) <= 1 for ch in tree.children.values()) and len(tree.roots) == 1


def test_dot_writes_gtsams_format_and_nnz_counts_the_upper_triangle_and_the_separator_block():
    s = IncrementalSolver(relinearize_skip=1)
    s.update(
        [PriorFactor.create(X(0), np.zeros(6), 0.1), PriorFactor.create(L(1), np.zeros(2), 1.0)],
        {X(0): np.zeros(6), L(1): np.zeros(2)},
    )
    report = s.update(
        [GPPriorFactor.wnoa(X(0), X(1), 0.5, QC), RangeFactor.create(X(1), L(1), 1.0, 0.1)], {X(1): np.ones(6)}
    )
    text = s.tree.dot()
    assert text.startswith("digraph G{\n") and text.endswith("\n}") and text.count("[label=") == len(s.tree)
    assert gtsam_key(X(2)) == 8646911284551352322 and gtsam_key(L(0)) == 7782220156096217088  # Symbol('x', 2)...
    # a dense count of R's upper-triangular structure: every clique's rows over its frontal and separator columns
    dims = {k: (6 if k.symbol == "x" else 2) for k in (X(0), X(1), L(1))}
    expected = 0
    for c in s.tree.cliques.values():
        nf, ns = sum(dims[k] for k in c.frontals), sum(dims[k] for k in c.separator)
        expected += int(np.count_nonzero(np.triu(np.ones((nf, nf))))) + nf * ns
    assert report.tree_nnz == expected == tree_nnz(s.tree.cliques.values())
    assert sum(clique_nnz(c) for c in s.tree.cliques.values()) == expected


def _gtsam_graph(gtsam, gfs):
    graph = gtsam.GaussianFactorGraph()
    for gf in gfs:
        args = [x for k, block in zip(gf.keys, gf.blocks, strict=True) for x in (gtsam_key(k), np.asarray(block))]
        graph.add(gtsam.JacobianFactor(*args, np.asarray(gf.rhs), gtsam.noiseModel.Unit.Create(len(gf.rhs))))
    return graph


@pytest.mark.parametrize(
    ("problem", "order"),
    [
        (BUSHY, BUSHY_ORDER),
        (TRAJECTORY, ORDERINGS["trajectory"]["interleaved"]),
        (TRAJECTORY, ORDERINGS["trajectory"]["xl"]),
        (BEACONS, ORDERINGS["beacons"]["states_first"]),
    ],
)
def test_dot_of_a_given_ordering_is_gtsams_eliminate_multifrontal(problem, order):
    gtsam = optional_import("gtsam", "gtsam")
    factors, values = [spec.factor(f) for f in problem["factors"]], spec.values(problem["values"])
    gfs = [gf for group in linearize(factors, values) for gf in group.gaussian_factors()]
    ours = BayesTree.from_factors(gfs, spec.ordering(order, problem["variables"]))
    ordering = gtsam.Ordering()
    for k in order:
        ordering.push_back(gtsam_key(spec.key(k)))
    theirs = _gtsam_graph(gtsam, gfs).eliminateMultifrontal(ordering).dot()
    assert sorted(ours.dot().splitlines()) == sorted(theirs.splitlines())
    if one_child_each(ours):
        assert ours.dot() == theirs
    assert tree_dot(ours) == ours.dot()


def test_tree_nnz_and_dot_after_every_isam2_update_match_gtsam_given_the_same_order():
    gtsam = optional_import("gtsam", "gtsam")
    rng = np.random.default_rng(7)

    def custom(keys, m):  # a linear factor of GTSAM's with the structure of ours (values do not matter here)
        blocks = [rng.normal(size=(m, 6 if k.symbol == "x" else 2)) for k in keys]

        def error(this, values, H):
            if H is not None:
                for i, block in enumerate(blocks):
                    H[i] = block
            return sum(b @ values.atVector(gtsam_key(k)) for k, b in zip(keys, blocks, strict=True)) - 1.0

        return gtsam.CustomFactor(gtsam.noiseModel.Unit.Create(m), [gtsam_key(k) for k in keys], error)

    params = gtsam.ISAM2Params()
    params.setRelinearizeThreshold(1e9)
    params.enableDetailedResults = True
    isam, ours = gtsam.ISAM2(params), IncrementalSolver(relinearize_threshold=float("inf"))
    exact = 0
    for i in range(12):
        factors = (
            [(GPPriorFactor.wnoa(X(i - 1), X(i), 0.5, QC), 12)]
            if i
            else [(PriorFactor.create(X(0), np.zeros(6), 1.0), 6)]
        )
        new = [X(i)]
        if i == 0 or i == 5:
            lm = L(i // 5)
            factors.append((PriorFactor.create(lm, np.zeros(2), 1.0), 2))
            new.append(lm)
        for j in range(2):
            if i % (j + 2) == 0 and (j == 0 or i >= 5):
                factors.append((RangeFactor.create(X(i), L(j), 1.0, 1.0), 1))
        report = ours.update([f for f, _ in factors], {k: rng.normal(size=6 if k.symbol == "x" else 2) for k in new})
        groups = gtsam.KeyGroupMap()
        for position, k in enumerate(report.reeliminated):
            groups.insert2(gtsam_key(k), position)
        graph, theta = gtsam.NonlinearFactorGraph(), gtsam.Values()
        for f, m in factors:
            graph.add(custom(f.keys, m))
        for k in new:
            theta.insert(gtsam_key(k), np.zeros(6 if k.symbol == "x" else 2))
        result = isam.update(graph, theta, [], groups)
        assert report.tree_nnz == isam.treeNnz() == result.getTreeNnz(), i
        assert sorted(ours.tree.dot().splitlines()) == sorted(isam.dot().splitlines()), i
        if one_child_each(ours.tree):
            assert ours.tree.dot() == isam.dot(), i
            exact += 1
    assert exact >= 3


def test_run_writes_the_final_tree_with_tree_dot_and_refuses_it_for_another_method(tmp_path, capsys):
    path = tmp_path / "tree.dot"
    code = main(["run", "--dataset", "synthetic", "--max-poses", "20", "--tree-dot", str(path)])
    assert code == 0 and path.read_text().startswith("digraph G{\n") and '[label="' in path.read_text()
    code = main(
        ["run", "--dataset", "synthetic", "--max-poses", "5", "--method", "pb", "--tree-dot", str(tmp_path / "b.dot")]
    )
    err = capsys.readouterr().err
    assert code == 2 and "--tree-dot" in err and "btgp" in err and not (tmp_path / "b.dot").exists()

"""Evaluation against oracles the other tests do not use, and the inputs it once answered wrongly.

- Alignment against a brute-force minimisation of Σ ‖yᵢ - (s R(φ) xᵢ + t)‖² (SciPy BFGS from 24 starting angles) on
  the cases a closed form gets wrong: a truth that is the mirror image of the estimate (Umeyama's det = -1 case:
  the answer must stay a rotation, and its scale tr(DS)/σ², not the sum of the singular values), two points,
  collinear points.
- The ANEES of landmarks when a run saw none: left out, the band over the runs that have one (it made the whole
  summary a NaN, refused).
- Fidelity's heading difference modulo 2π; a TUM quaternion that is no rotation (|q| = 2 was read as θ = 0).
"""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import minimize
from scipy.stats import chi2

from steam_ref.errors import DataError, SteamError
from steam_ref.evaluate import align_planar, read_tum
from steam_ref.paper.consistency import summarize
from steam_ref.paper.fidelity import AuthorsRun, compare


def _cost(x, y, angle, t, s):
    c, si = np.cos(angle), np.sin(angle)
    return float(np.sum((y - (s * x @ np.array([[c, -si], [si, c]]).T + t)) ** 2))


def _brute_force(x, y, with_scale):
    """The least cost over rotations, translations (and log-scales) from many starts: an independent oracle."""
    best = np.inf
    for a0 in np.linspace(-np.pi, np.pi, 24, endpoint=False):
        start = [a0, *(y.mean(0) - x.mean(0))] + ([0.0] if with_scale else [])
        r = minimize(
            lambda p: _cost(x, y, p[0], p[1:3], np.exp(p[3]) if with_scale else 1.0),
            start,
            method="BFGS",
            options={"gtol": 1e-12},
        )
        best = min(best, r.fun)
    return best


def _cases():
    rng = np.random.default_rng(7)
    x5, x3, x2 = rng.normal(size=(5, 2)), rng.normal(size=(3, 2)), rng.normal(size=(2, 2))
    line = np.linspace(0, 1, 4)[:, None] * [1.0, 2.0]
    return {
        "mirror image, noisy": (x5, x5 * [1, -1] + rng.normal(0, 0.01, (5, 2))),
        "three points mirrored and scaled": (x3, x3 * [-1, 1] * 2.5),
        "two points": (x2, rng.normal(size=(2, 2))),
        "collinear, rotated": (line, line @ np.array([[0.0, 1.0], [-1.0, 0.0]]) + 5),
        "collinear, mirrored": (line, line * [-1, 1] + 2),
        "unrelated": (x5, rng.normal(size=(5, 2))),
    }


@pytest.mark.parametrize("with_scale", [False, True])
@pytest.mark.parametrize("case", list(_cases()))
def test_alignment_reaches_the_brute_force_minimum(case, with_scale):
    x, y = _cases()[case]
    found = align_planar(x, y, with_scale=with_scale)
    ours = _cost(x, y, found.angle, found.translation, found.scale)
    assert ours <= _brute_force(x, y, with_scale) + 1e-12 * (1 + float(np.sum(y * y)))
    assert np.linalg.det(found.rotation) == pytest.approx(1.0, abs=1e-15)  # never a reflection


def test_a_run_that_saw_no_landmark_is_left_out_of_the_landmark_anees():
    rng = np.random.default_rng(3)

    def run(landmarks):
        return {
            "e": {"pose": rng.chisquare(3, 5).tolist(), "velocity": rng.chisquare(3, 5).tolist()}
            | {"landmark": landmarks, "warnings": []}
        }

    results = {0: run([]), 1: run([1.0, 3.0]), 2: run([2.0]), 3: run([])}
    row = summarize(results, ("e",))["estimators"]["e"]["landmark"]
    assert row["anees"] == pytest.approx((2.0 + 2.0) / 2)  # the two runs that saw one
    assert row["band"] == pytest.approx([chi2.ppf(0.025, 2 * 2) / 2, chi2.ppf(0.975, 2 * 2) / 2])  # N = 2 runs
    with pytest.raises(SteamError, match="no run has a landmark NEES"):
        summarize({0: run([]), 1: run([])}, ("e",))


def test_fidelity_compares_headings_modulo_a_turn():
    n = 4
    poses = np.column_stack([np.arange(n, dtype=float), np.zeros(n), np.full(n, 3.0)])
    authors = AuthorsRun(
        "x", np.arange(n), poses, np.zeros((n, 3)), {1: np.zeros(2)}, None, None, None, np.zeros(n), None
    )
    ours = poses + [0.0, 0.0, 2 * np.pi]  # the same poses, one heading a turn on
    ours[2, 2] += 0.25
    result = SimpleNamespace(
        state_poses=np.arange(n), landmarks={1: np.zeros(2)}, trajectory=ours, covariances=None, n_states=n
    )
    truth = np.column_stack([np.arange(n), poses])
    fid, _ = compare(result, authors, truth)
    assert fid.heading_max_rad == pytest.approx(0.25, abs=1e-12)


@pytest.mark.parametrize("q", ["0 0 0 2", "0 0 0.5 0.5", "0 0 0 0"])
def test_a_tum_quaternion_that_is_no_rotation_is_refused(tmp_path, q):
    (tmp_path / "a.txt").write_text(f"1 0 0 0 0 0 0 1\n2 0 0 0 {q}\n")
    with pytest.raises(DataError, match=r"line 2: the quaternion .* not a rotation"):
        read_tum(tmp_path / "a.txt")
    (tmp_path / "b.txt").write_text("1 0 0 0 0 0 0.7071 0.7071\n")  # four decimals, as the TUM benchmark's files
    assert read_tum(tmp_path / "b.txt")[1][0, 2] == pytest.approx(np.pi / 2, abs=1e-12)

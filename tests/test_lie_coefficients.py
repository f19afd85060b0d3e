"""Each coefficient a Lie group lists (``LieGroup.coefficients``) against its definition in 50-digit mpmath.

The battery (``test_lie_groups.py``) sweeps every group's matrices; a group that also lists the coefficients of
its rotation angle (SO(3), SE(3)) has each of them checked here one by one. SE(2)'s matrices carry its
coefficients, so it lists none and is not a case here (a group joins by listing them).
"""

from __future__ import annotations

import numpy as np
import pytest
from test_lie_groups import GROUPS, REL, _dense_angles, mp

from steam_ref.lie.coefficients import coefficients_at

LISTING = [g for g in GROUPS if g.coefficient_definitions]


@pytest.mark.parametrize("group", LISTING, ids=lambda g: g.name)
def test_every_listed_coefficient_against_its_definition_at_50_digits(group):
    """Each coefficient the group lists (``coefficients``) against its definition (``coefficient_definitions``) in
    mpmath, at 460 angles from 1e-12 to π: dense enough to land inside and on both sides of any branch about a
    coefficient's root, and 1 ulp either side of the series switch. The definitions are the plain closed forms,
    evaluated with 120 digits so that their own cancellation (up to 50 digits at θ = 1e-12) leaves more than 50."""
    angles = _dense_angles(group)
    ours = group.coefficients(angles)
    assert set(ours) == set(group.coefficient_definitions)
    failures, worst = [], 0.0
    with mp.workdps(120):
        for name, definition in group.coefficient_definitions.items():
            for theta, got in zip(angles, ours[name], strict=True):
                want = definition(mp.mpf(float(theta)), mp)
                err = float(abs(mp.mpf(float(got)) - want) / abs(want)) if want else abs(float(got))
                worst = max(worst, err)
                if err > REL:
                    failures.append(
                        f"{name}({theta!r}) = {got!r}, 50 digits: {mp.nstr(want, 20)} (relative error {err:.2e})"
                    )
    assert not failures, f"{len(failures)} coefficients off by more than {REL}:\n" + "\n".join(failures[:20])
    assert worst <= REL


def test_every_coefficient_within_1e_14_next_to_the_roots_and_the_switch_by_mpmaths_own_derivatives():
    """docs/derivations.md §13 measures every coefficient within 1e-14 of 50 digits from 1e-12 to π. Here each is
    held to 1e-14 where that is hardest: within 1e-15 to 0.0801 of the roots of B1 and A2 (the branch that sums
    their numerators about the root, and both sides of its edge at 0.08), of the series switch at 2 and of π, and on
    a log grid from 1e-12. The oracle is not ``DEFINITIONS``: A, B, C, D, α = (θ/2) cot(θ/2) and γ = (1 - α)/θ are
    written here, every derivative is mpmath's numerical d/dθ at 80 digits, and the roots are found by mpmath."""
    with mp.workdps(80):
        base = {
            "A": lambda t: mp.sin(t) / t,
            "B": lambda t: (1 - mp.cos(t)) / t,
            "C": lambda t: (t - mp.sin(t)) / t**2,
            "D": lambda t: (1 - mp.cos(t)) / t**2,
            "alpha": lambda t: t / 2 * mp.cot(t / 2),
        }
        base["gamma"] = lambda t: (1 - base["alpha"](t)) / t
        d = {f"{n}{k}": (lambda t, f=base[n], k=k: mp.diff(f, t, k)) for n in base for k in (1, 2)}
        oracle = base | {n: d[n] for n in ("A1", "B1", "C1", "D1", "alpha1", "A2", "B2", "alpha2")}
        oracle |= {
            "Ct": lambda t: base["C"](t) / t,
            "A1t": lambda t: d["A1"](t) / t,
            "alpha1t": lambda t: d["alpha1"](t) / t,
            "gammat": lambda t: base["gamma"](t) / t,
            "E1": lambda t: base["C"](t) / t - d["C1"](t),
            "G1": lambda t: (2 * base["gamma"](t) + d["alpha1"](t)) / t,
            "G2": lambda t: -(base["gamma"](t) + d["alpha1"](t)) / t,
        }
        centres = [mp.findroot(d["B1"], 2.33), mp.findroot(d["A2"], 2.08), mp.mpf(2), +mp.pi]
        offsets = (0.0, 1e-15, 1e-12, 1e-9, 1e-6, 1e-3, 0.05, 0.0799, 0.08, 0.0801)
        near = {float(c + s * o) for c in centres for o in offsets for s in (-1, 1)}
        angles = np.array(sorted(a for a in near | set(np.geomspace(1e-12, np.pi, 40)) if 1e-12 <= a <= np.pi))
        ours = coefficients_at(angles)
        assert set(ours) == set(oracle)
        worst = {}
        for name, f in oracle.items():
            errors = []
            for theta, got in zip(angles, ours[name], strict=True):
                want = f(mp.mpf(float(theta)))
                errors.append(float(abs(mp.mpf(float(got)) - want) / abs(want)))
            worst[name] = (max(errors), float(angles[int(np.argmax(errors))]))
    assert max(err for err, _ in worst.values()) <= 1e-14, {n: w for n, w in worst.items() if w[0] > 1e-14}

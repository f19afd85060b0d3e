"""Each coefficient a Lie group lists (``LieGroup.coefficients``) against its definition in 50-digit mpmath.

The battery (``test_lie_groups.py``) sweeps every group's matrices; a group that also lists the coefficients of
its rotation angle (SO(3), SE(3)) has each of them checked here one by one. SE(2)'s matrices carry its
coefficients, so it lists none and is not a case here (a group joins by listing them).
"""

from __future__ import annotations

import pytest
from test_lie_groups import GROUPS, REL, _dense_angles, mp

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

"""Golden values: today's results must not move unless a commit says so.

``tests/data/golden.json`` was made from the code before the one-Model change (commit in the
file) and is bitwise what the code gives now. On a machine of the same CPU level the scalars must
match exactly and the histories' hashes must be equal; on another level (other vector units, other
rounding in faer's kernels) the scalars are compared to 1e-12 relative and the hashes skipped.
Eigenvalues (LAPACK through numpy) are compared to 1e-9 relative everywhere (see
``golden_cases.RELATIVE``). A change meant to change
results regenerates the file (``python scripts/golden.py --write``) in a commit of its own that
gives the new numbers.
"""

from __future__ import annotations

import json

import flexclear
import golden_cases as gc
import pytest

GOLDEN = json.loads(gc.GOLDEN_FILE.read_text())
SAME_LEVEL = GOLDEN["cpu"] == gc.cpu_level()


def test_every_case_has_a_golden_value():
    assert sorted(GOLDEN["cases"]) == sorted(gc.CASES)


@pytest.mark.parametrize("name", sorted(gc.CASES))
def test_golden(name):
    got = gc.CASES[name](flexclear)
    bitwise = SAME_LEVEL and name not in gc.NOT_BITWISE
    rel = gc.RELATIVE.get(name, 1e-12)
    diffs = gc.compare(GOLDEN["cases"][name], got, bitwise, rel=rel)
    assert not diffs, f"{name} ({'bitwise' if bitwise else f'{rel:g} relative'}):\n" + "\n".join(diffs)


def test_the_comparison_catches_a_last_bit_change():
    # the check itself: a one-ulp change of a scalar and a changed hash are both differences
    case = GOLDEN["cases"]["yoke-1e-4-modified"]
    moved = dict(case, max_force=case["max_force"] * (1 + 2**-52), history="0" * 64)
    assert len(gc.compare(case, moved, True)) == 2
    assert gc.compare(case, moved, False) == []

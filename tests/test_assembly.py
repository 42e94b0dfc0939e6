"""The train assembly reproduces the assembled arrays of every shipped system bit for bit (M, K, C, G, K_W, every
coupling vector, phases, the kernel's packed arrays and label), against the fingerprints recorded before the
kinds registry replaced the per-kind builders (tests/_fingerprints.py)."""
from __future__ import annotations

import json


import pytest

import _fingerprints

REF = json.loads(_fingerprints.DATA.read_text())
CASES = dict(_fingerprints.cases())


def test_every_recorded_case_is_built():
    assert sorted(CASES) == sorted(REF)


@pytest.mark.parametrize("case", sorted(REF))
def test_assembly_is_bit_identical(case):
    assert _fingerprints.fingerprint(CASES[case]()) == REF[case]

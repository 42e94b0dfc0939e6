"""The train assembly reproduces the assembled arrays of every shipped system (M, K, C, G, K_W, every coupling
vector, phases, the kernel's packed arrays and label), against the fingerprints recorded before the kinds registry
replaced the per-kind builders: floats within 1e-10 relative per entry, on any CPU (tests/_fingerprints.py)."""
from __future__ import annotations

import json

import numpy as np
import pytest

import _fingerprints

REF = json.loads(_fingerprints.DATA.read_text())
CASES = dict(_fingerprints.cases())


def test_every_recorded_case_is_built():
    assert sorted(CASES) == sorted(REF)


@pytest.mark.parametrize("case", sorted(REF))
def test_assembly_reproduces_the_record(case):
    assert _fingerprints.differences(_fingerprints.fingerprint(CASES[case]()), REF[case]) == []


def test_a_changed_entry_is_caught_and_last_bits_are_not():
    """The comparison is no hash of everything: last-bit noise on every entry (relative 4e-16, plus 1e-14 of the
    largest entry, as a cancelling sum has it) passes, while a relative change of 1e-6 in one entry of a 12 x 12
    matrix, a change of 1e-9 of the largest entry in one small entry, a flipped sign and a changed integer fail."""
    rng = np.random.default_rng(1)
    m = rng.normal(size=(12, 12)) * np.logspace(-3, 5, 12)
    ref = _fingerprints._summary([m, np.arange(5)])
    noisy = m * (1 + rng.uniform(-4e-16, 4e-16, m.shape)) + rng.uniform(-1e-14, 1e-14, m.shape) * np.abs(m).max()
    assert all(map(_fingerprints._close, _fingerprints._summary([noisy, np.arange(5)]), ref))
    for i, j in ((3, 9), (0, 11)):   # entries above the floor (1e-4 of the largest)
        bad = m.copy()
        bad[i, j] *= 1 + 1e-6
        assert not _fingerprints._close(_fingerprints._summary([bad])[0], ref[0])
    bad = m.copy()
    bad[3, 4] += 1e-9 * np.abs(m).max()   # an entry of size ~1 next to 2e5: compared absolutely
    assert not _fingerprints._close(_fingerprints._summary([bad])[0], ref[0])
    flipped = m.copy()
    flipped[0, 0] = -flipped[0, 0]
    assert not _fingerprints._close(_fingerprints._summary([flipped])[0], ref[0])
    assert not _fingerprints._close(_fingerprints._summary([np.arange(1, 6)])[0], ref[1])

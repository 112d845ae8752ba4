"""The repository's copy of the contract examples (tests/contract) is the contract's, byte for byte.

A user's clone has no ../shared; where it is present (development, CI), the copy must match it, so the
tests that read the copy test the binding formats.
"""

from __future__ import annotations

import pytest

from tests.conftest import OUTSIDE_SPEC, SPEC


def _files(root):
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_copy_holds_every_example():
    names = _files(SPEC / "examples")
    assert "run_grill_brick_1.5mm/data.csv" in names and "springs_4.yaml" in names
    assert (SPEC / "CONTRACT.md").stat().st_size > 1000


@pytest.mark.skipif(not OUTSIDE_SPEC.is_dir(), reason="the binding contract is not beside this checkout")
def test_copy_matches_the_binding_contract():
    assert _files(SPEC / "examples") == _files(OUTSIDE_SPEC / "examples")
    assert (SPEC / "CONTRACT.md").read_bytes() == (OUTSIDE_SPEC / "CONTRACT.md").read_bytes()

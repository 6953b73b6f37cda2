"""controller/legs.py: pure functions of the virtual legs and the chassis' integrals."""
import pytest

from wheelleg.controller.legs import unwind


@pytest.mark.parametrize("integral, step, expected", [
    (-0.157, 0.001, -0.156),  # a stale trim unwinds
    (0.1, -0.2, 0.0),  # never past zero
    (0.1, 0.05, 0.1),  # it must not grow
    (-0.1, -0.01, -0.1),
    (0.0, 0.1, 0.0),  # nothing to unwind
])
def test_unwind_only_moves_an_integral_towards_zero(integral, step, expected):
    assert unwind(integral, step) == pytest.approx(expected)

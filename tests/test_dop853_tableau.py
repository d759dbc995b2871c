"""The vendored DOP853 tableau (synth/physics/dop853_tableau.py) satisfies the Runge-Kutta
order conditions and equals scipy's copy of Hairer's coefficients."""

import importlib

import numpy as np
import pytest

from synth.physics import dop853_tableau as t

NS = t.N_STAGES


def test_weights_sum_to_one():
    # Order 1: sum b_i = 1 (consistency); 1e-15 is the rounding of 12 terms of size <= 10.
    assert t.B.sum() == pytest.approx(1.0, abs=1e-14)


def test_row_sums_equal_the_nodes():
    # The simplifying condition sum_j a_ij = c_i for every stage, the extra (dense output)
    # stages included; the rounding of up to 15 terms of size <= 50: 1e-13.
    np.testing.assert_allclose(t.A.sum(axis=1), t.C, rtol=0, atol=1e-13)


@pytest.mark.parametrize("q", range(1, 9))
def test_quadrature_conditions_to_order_8(q):
    # sum b_i c_i^(q-1) = 1/q for q = 1 .. 8: the weights integrate polynomials of degree 7
    # exactly, as an 8th-order method's must (Hairer, Norsett & Wanner I, II.2).
    assert np.dot(t.B, t.C[:NS] ** (q - 1)) == pytest.approx(1.0 / q, abs=1e-13)


def test_error_estimators_are_consistent():
    # Each error estimator is a difference of two consistent methods: its weights sum to 0.
    assert t.E3.sum() == pytest.approx(0.0, abs=1e-14)
    assert t.E5.sum() == pytest.approx(0.0, abs=1e-14)


def test_equals_scipys_copy_of_hairers_coefficients():
    # scipy (a dependency, every supported version) carries Hairer's coefficients in a
    # private module; if it moves, this test fails and says so rather than passing unseen.
    ref = importlib.import_module("scipy.integrate._ivp.dop853_coefficients")
    for name in ("A", "B", "C", "E3", "E5", "D"):
        assert np.array_equal(getattr(t, name), getattr(ref, name)), name
    assert (t.N_STAGES, t.N_STAGES_EXTENDED, t.INTERPOLATOR_POWER) == (
        ref.N_STAGES,
        ref.N_STAGES_EXTENDED,
        ref.INTERPOLATOR_POWER,
    )

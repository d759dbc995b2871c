"""The vectorisable elementary functions against libm (synth.vecmath).

Tolerances: the module promises a few ulp for cis on |theta| < 2^19 pi (fdlibm's kernels
after a two-part reduction by pi/2), an ulp or two for exp_small on |u| <= 1, and about
2^J ulp for exp_small of u / 2^J squared J times, J from halvings_for (the kernels' scaling
of larger arguments: each squaring doubles the relative error).
"""

import math

import numba
import numpy as np
import pytest

from synth.vecmath import cis, exp_small, halvings_for

ULP = np.finfo(float).eps
#: Largest ``|theta|`` (rad) cis promises within a few ulp (its docstring's bound).
CIS_MAX = 2.0**19 * math.pi


@numba.njit
def _cis_many(theta, c, s):
    for i in range(theta.shape[0]):
        c[i], s[i] = cis(theta[i])


@numba.njit
def _exp_squared_many(u, halvings, out):
    # exp(u 2^halvings) as the kernels take it: exp_small(u), squared `halvings` times
    for i in range(u.shape[0]):
        e = exp_small(u[i])
        for _ in range(halvings):
            e = e * e
        out[i] = e


def test_cis_within_a_few_ulp_of_libm():
    rng = np.random.default_rng(0)
    theta = np.concatenate(
        [rng.uniform(-4, 4, 20000), rng.uniform(-CIS_MAX, CIS_MAX, 20000), [0.0, math.pi / 4]]
    )
    c = np.empty_like(theta)
    s = np.empty_like(theta)
    _cis_many(theta, c, s)
    # absolute error against |cos| + |sin| <= sqrt 2: a few ulp of the unit circle, plus
    # the reduction's error, which grows with |theta| (2^19 pi * 2^-86 or so: negligible)
    assert np.max(np.abs(c - np.cos(theta))) < 4 * ULP
    assert np.max(np.abs(s - np.sin(theta))) < 4 * ULP


@pytest.mark.parametrize("halvings", [0, 3, 8])
def test_exp_small_squared_within_its_bound(halvings):
    u = np.linspace(-1.0, 1.0, 4001)
    out = np.empty_like(u)
    _exp_squared_many(u, halvings, out)
    exact = np.exp(u * 2.0**halvings)
    assert np.max(np.abs(out / exact - 1.0)) < 4 * 2.0**halvings * ULP


def test_exp_small_is_exact_at_zero_and_one():
    assert exp_small(0.0) == 1.0
    assert abs(exp_small(1.0) / math.e - 1.0) < 2 * ULP


@pytest.mark.parametrize(
    "largest, halvings", [(0.0, 0), (0.5, 0), (1.0, 0), (1.5, 1), (2.0, 1), (300.0, 9)]
)
def test_halvings_bring_the_argument_into_the_unit_interval(largest, halvings):
    assert halvings_for(largest) == halvings
    assert largest / 2.0**halvings <= 1.0

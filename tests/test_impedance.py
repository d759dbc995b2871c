"""Plate impedance at the impact point (docs/physics.md, "Plate impedance")."""

import math

import pytest

from synth.errors import ParameterError
from synth.physics import impedance
from synth.physics.scene import Plate

MDF18 = Plate("mdf-18", 0.018, 1.227, 0.49)


def test_infinite_plate_impedance_thesis_table_3_4():
    # Thesis Table 3.4: Z_inf = 1629 N s/m for the 18 mm MDF board (+- 2).
    assert impedance.infinite_plate_impedance(MDF18) == pytest.approx(1629.0, abs=2.0)


def test_infinite_plate_impedance_two_forms_agree():
    # 8 sqrt(D rho h) = 4 h^2 sqrt(E rho / (3 (1 - nu^2))) (algebraic identity, 1e-12).
    m = MDF18.material
    alt = 4 * MDF18.thickness**2 * math.sqrt(m.young * m.density / (3 * (1 - m.poisson**2)))
    assert impedance.infinite_plate_impedance(MDF18) == pytest.approx(alt, rel=1e-12)


def test_edge_and_corner_values():
    # Eichler's free edge 0.29 Z_inf and the thesis' thick-board corner ratio 7.5 (exact).
    z = impedance.infinite_plate_impedance(MDF18)
    assert impedance.edge_impedance(MDF18) == pytest.approx(0.29 * z, rel=1e-12)
    assert impedance.corner_impedance(MDF18) == pytest.approx(z / 7.5, rel=1e-12)


def test_point_admittance_regimes():
    # Middle (beyond the critical distance): 1/Z_inf; on an edge far from corners:
    # 1/Z_edge; at a corner: 1/Z_corner (the blend's end values, 1e-12).
    tau = 110e-6
    dc = impedance.critical_distance(MDF18, tau)
    z = impedance.infinite_plate_impedance(MDF18)
    assert impedance.point_admittance(MDF18, MDF18.centre, tau) == pytest.approx(1 / z, rel=1e-12)
    assert impedance.point_admittance(MDF18, (0.6, 0.0), tau) == pytest.approx(
        1 / (0.29 * z), rel=1e-12
    )
    assert impedance.point_admittance(MDF18, (0.0, 0.0), tau) == pytest.approx(7.5 / z, rel=1e-12)
    assert impedance.point_admittance(MDF18, (0.6, dc * 1.0001), tau) == pytest.approx(
        1 / z, rel=1e-12
    )


def test_point_admittance_decreases_away_from_edge():
    # The edge is felt less with distance: monotone between the edge and d_c.
    tau = 110e-6
    dc = impedance.critical_distance(MDF18, tau)
    betas = [
        impedance.point_admittance(MDF18, (0.6, f * dc), tau) for f in (0, 0.25, 0.5, 0.75, 1.0)
    ]
    assert all(a > b for a, b in zip(betas, betas[1:]))


def test_critical_distance_formula():
    # d_c = c_g tau / 2 with c_g = 2 sqrt(omega) (D / rho h)^(1/4), omega = pi / tau.
    tau = 110e-6
    cg = 2 * math.sqrt(math.pi / tau) * (MDF18.flexural_rigidity / MDF18.surface_density) ** 0.25
    assert impedance.critical_distance(MDF18, tau) == pytest.approx(cg * tau / 2, rel=1e-12)


def test_point_admittance_non_free_boundary_is_infinite_plate():
    # Only free edges soften the plate in this model (documented); others: 1/Z_inf.
    p = Plate("mdf-18", 0.018, 1.227, 0.49, boundary="clamped")
    assert impedance.point_admittance(p, (0.0, 0.0), 1e-4) == pytest.approx(
        1 / impedance.infinite_plate_impedance(p), rel=1e-12
    )


@pytest.mark.parametrize("pos", [(-0.01, 0.1), (0.1, 0.5), (float("nan"), 0.1)])
def test_point_admittance_rejects_positions_off_the_plate(pos):
    with pytest.raises(ParameterError, match="position"):
        impedance.point_admittance(MDF18, pos, 1e-4)


@pytest.mark.parametrize("tau", [0.0, -1e-4, float("inf")])
def test_critical_distance_rejects_bad_contact_time(tau):
    with pytest.raises(ParameterError, match="contact_time"):
        impedance.critical_distance(MDF18, tau)

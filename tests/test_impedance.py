"""Plate impedance at the impact point (docs/physics.md, "Plate impedance")."""

import math
from dataclasses import replace

import numpy as np
import pytest

from synth.errors import ParameterError
from synth.physics import impedance
from synth.physics.scene import Plate
from validation.rows import corner_impedance, edge_impedance
from validation.shear import kirchhoff_wave_speeds, mindlin_band_impedance

MDF18 = Plate("mdf-18", 0.018, 1.227, 0.49)
#: The 18 mm board with a transverse shear modulus a fifth of the isotropic one (about MDF's
#: E_t / E), set by hand: the closed forms below hold for any G_t.
_G_ISO = 5.689e9 / (2.0 * 1.4)
SOFT18 = Plate(replace(MDF18.material, transverse_shear=0.2 * _G_ISO), 0.018, 1.227, 0.49)


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
    assert edge_impedance(MDF18) == pytest.approx(0.29 * z, rel=1e-12)
    assert corner_impedance(MDF18) == pytest.approx(z / 7.5, rel=1e-12)


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


# --------------------------------------------------------------------------------------
# Mindlin (thick) plate
# --------------------------------------------------------------------------------------


def test_mindlin_admittance_tends_to_kirchhoff_at_low_frequency():
    # k h -> 0: Mindlin's Re Y -> 1 / (8 sqrt(D rho h)); the correction grows as omega
    # (shear, k^2 D / (kappa G h), with k^2 ~ omega): 4.2e-5 at 1 Hz, so 1e-6 at 0.02 Hz.
    beta = 1.0 / impedance.infinite_plate_impedance(MDF18)
    assert impedance.mindlin_point_admittance(MDF18, 0.02) == pytest.approx(beta, rel=1e-6)
    f = np.array([1e2, 1e3, 1e4, 1e5])
    y = impedance.mindlin_point_admittance(MDF18, f)
    assert np.all(np.diff(y) > 0.0) and np.all(y > beta)  # shear softens the plate


@pytest.mark.parametrize("shear_ratio", [1.0, 0.2])
@pytest.mark.parametrize("frequency", [1e3, 4.5e3, 2e4])
def test_mindlin_admittance_is_the_wavenumber_integral(frequency, shear_ratio):
    # The exact wavenumber integral of a point force, Re Y = Re[i omega / (4 pi) Int N / P ds],
    # evaluated with a small loss (E, G -> (1 + i eta) E, G) that moves the pole off the axis,
    # and extrapolated to eta -> 0 (error linear in eta: Richardson from eta and eta / 2).
    from scipy.integrate import quad

    # With shear_ratio < 1 the plate's transverse shear modulus is that fraction of the
    # isotropic E / (2 (1 + nu)) (an orthotropic board), which enters through G alone.
    w = 2.0 * np.pi * frequency
    plate = MDF18 if shear_ratio == 1.0 else SOFT18
    m = MDF18.material
    h = MDF18.thickness
    shear = impedance.SHEAR_COEFFICIENT * shear_ratio * m.young / (2.0 * (1.0 + m.poisson))
    inertia = m.density * h**3 / 12.0
    s1 = impedance.mindlin_wavenumbers(plate, w)[0]

    def re_y(eta):
        D = MDF18.flexural_rigidity * (1.0 + 1j * eta)
        g = shear * (1.0 + 1j * eta)

        def integrand(s):
            p = (s - w * w * m.density / g) * (D * s - inertia * w * w) - m.density * h * w * w
            n = 1.0 + (D * s - inertia * w * w) / (g * h)
            return (1j * w / (4.0 * np.pi) * n / p).real

        pts = [s1 * (1.0 + d) for d in (-0.2, -0.05, -0.01, 0.0, 0.01, 0.05, 0.2)]
        return quad(integrand, 0.0, 400.0 * s1, points=pts, limit=4000)[0]

    extrapolated = 2.0 * re_y(0.005) - re_y(0.01)
    closed = impedance.mindlin_point_admittance(plate, frequency)
    assert extrapolated == pytest.approx(closed, rel=1e-3)


def test_mindlin_simply_supported_square_published_frequency():
    # Simply supported square, a / h = 10, nu = 0.3, kappa = 5/6: the fundamental's
    # omega h sqrt(rho / G) = 0.0930 by Mindlin's theory (exact 3D elasticity 0.0932, thin
    # plate with rotary inertia 0.0955; Srinivas, Joga Rao & Rao, J. Sound Vib. 12 (1970)
    # 187-199, tabulate the exact value beside Mindlin's; Reddy, "Theory and Analysis of
    # Elastic Plates and Shells", 2nd ed.).
    from synth.physics.materials import Material

    mat = Material("test", 1000.0, 1e9, 0.3)
    plate = Plate(mat, 0.1, 1.0, 1.0, boundary="simply-supported")
    w = impedance.mindlin_angular_frequency(plate, 2.0 * np.pi**2)
    shear = mat.young / (2.0 * (1.0 + mat.poisson))
    assert w * 0.1 * np.sqrt(mat.density / shear) == pytest.approx(0.0930, abs=6e-5)


def test_mindlin_dispersion_roots_and_frequency_agree():
    # mindlin_angular_frequency inverts the propagating root of mindlin_wavenumbers
    # (both solve P = 0; 1e-12), and both tend to Kirchhoff's k^4 = omega^2 rho h / D.
    w = 2.0 * np.pi * np.array([0.01, 1e3, 3e4])
    s1, s2 = impedance.mindlin_wavenumbers(MDF18, w)
    assert impedance.mindlin_angular_frequency(MDF18, s1) == pytest.approx(w, rel=1e-12)
    thin = w[0] * math.sqrt(MDF18.surface_density / MDF18.flexural_rigidity)
    assert s1[0] == pytest.approx(thin, rel=1e-5) and s2[0] == pytest.approx(-thin, rel=1e-5)


@pytest.mark.parametrize("plate", [MDF18, SOFT18], ids=["isotropic", "soft-shear"])
def test_mindlin_modal_mass_makes_the_modes_sum_to_the_infinite_plate(plate):
    # pi c / 2 times the modal density n = S / (4 pi) ds1 / d omega is Re Y of the infinite
    # plate (modes as a continuum), with c = 1 / (M mindlin_mass_factor): an identity of
    # the dispersion relation, to the finite difference's 1e-7, for any shear modulus.
    area = plate.length * plate.width
    for f in (1e3, 4.5e3, 2e4):
        w = 2.0 * np.pi * f
        dw = 1e-5 * w
        ds = impedance.mindlin_wavenumbers(plate, np.array([w - dw, w + dw]))[0]
        density = area / (4.0 * np.pi) * (ds[1] - ds[0]) / (2.0 * dw)
        s1 = impedance.mindlin_wavenumbers(plate, w)[0]
        c = 1.0 / (plate.mass * impedance.mindlin_mass_factor(plate, s1, w))
        y = impedance.mindlin_point_admittance(plate, f)
        assert 0.5 * np.pi * density * c == pytest.approx(y, rel=1e-7)


def test_mindlin_admittance_rejects_bad_frequency():
    with pytest.raises(ParameterError, match="frequency"):
        impedance.mindlin_point_admittance(MDF18, [1e3, -1.0])


# --------------------------------------------------------------------------------------
# Transverse shear modulus (a board softer across its thickness than in its plane)
# --------------------------------------------------------------------------------------


def test_isotropic_material_is_its_own_transverse_shear():
    # Without a transverse shear modulus the material is isotropic, G = E / (2 (1 + nu)), and
    # the Mindlin plate is bit for bit the one with that G given explicitly.
    m = MDF18.material
    assert m.transverse_shear is None and m.transverse_shear_modulus == _G_ISO
    given = Plate(replace(m, transverse_shear=_G_ISO), 0.018, 1.227, 0.49)
    w = 2.0 * np.pi * np.array([1e2, 5e3, 4e4])
    for a, b in zip(
        impedance.mindlin_wavenumbers(MDF18, w), impedance.mindlin_wavenumbers(given, w)
    ):
        assert np.array_equal(a, b)
    assert impedance.mindlin_point_admittance(MDF18, 3e3) == impedance.mindlin_point_admittance(
        given, 3e3
    )


def test_transverse_shear_must_be_positive():
    with pytest.raises(ParameterError, match="transverse_shear"):
        replace(MDF18.material, transverse_shear=-1.0)


@pytest.mark.parametrize("plate", [MDF18, SOFT18], ids=["isotropic", "soft-shear"])
def test_mindlin_dispersion_with_transverse_shear_closed_forms(plate):
    # Mindlin's dispersion with the plate's G (Graff, "Wave Motion in Elastic Solids",
    # section 8.3): the second branch's cut-off, where s2 = 0, is the thickness-shear
    # resonance omega_c = sqrt(12 kappa G / (rho h^2)); far above it the flexural phase
    # speed tends to the slower of sqrt(kappa G / rho) and sqrt(D / I) (here the shear
    # speed), from below (rounding; 2e-3 at 40 omega_c, the correction falling as 1/omega^2).
    m, h = plate.material, plate.thickness
    g = impedance.SHEAR_COEFFICIENT * m.transverse_shear_modulus
    w_c = math.sqrt(12.0 * g / (m.density * h * h))
    assert impedance.mindlin_wavenumbers(plate, w_c)[1] == pytest.approx(0.0, abs=1e-9)
    shear_speed = math.sqrt(g / m.density)
    assert shear_speed < math.sqrt(m.effective_modulus / m.density)
    far = impedance.mindlin_wave_speeds(plate, 40.0 * w_c / (2.0 * math.pi)).phase
    assert far < shear_speed and far == pytest.approx(shear_speed, rel=2e-3)


def test_mindlin_stiff_shear_limit_is_the_thin_plate_with_rotary_inertia():
    # G_t -> infinity: P(s) / (kappa G h) -> D s^2 - I omega^2 s - rho h omega^2 (Rayleigh's
    # plate: Kirchhoff with rotary inertia), whose root is
    # s = (I omega^2 + sqrt(I^2 omega^4 + 4 D rho h omega^2)) / (2 D). The shear term's
    # relative size is D s / (kappa G h): 1e-7 with G = 1e6 times the isotropic one.
    stiff = Plate(replace(MDF18.material, transverse_shear=1e6 * _G_ISO), 0.018, 1.227, 0.49)
    D, rh = stiff.flexural_rigidity, stiff.surface_density
    inertia = 700.0 * 0.018**3 / 12.0
    for f in (1e3, 2e4, 2e5):
        w2 = (2.0 * math.pi * f) ** 2
        rayleigh = (inertia * w2 + math.sqrt(inertia**2 * w2 * w2 + 4.0 * D * rh * w2)) / (2.0 * D)
        s1 = impedance.mindlin_wavenumbers(stiff, math.sqrt(w2))[0]
        assert s1 == pytest.approx(rayleigh, rel=1e-6)


@pytest.mark.parametrize("plate", [MDF18, SOFT18], ids=["isotropic", "soft-shear"])
def test_mindlin_group_speed_is_the_dispersion_slope(plate):
    # c_g = d omega / d k by central differences of the propagating root (1e-6), below the
    # thin plate's 2 c; at 1 Hz both speeds are Kirchhoff's (k h -> 0; 1e-3).
    for f in (1e2, 2.5e3, 3e4):
        w = 2.0 * math.pi * f
        dw = 1e-5 * w
        k = np.sqrt(impedance.mindlin_wavenumbers(plate, np.array([w - dw, w + dw]))[0])
        speeds = impedance.mindlin_wave_speeds(plate, f)
        assert speeds.group == pytest.approx(2.0 * dw / (k[1] - k[0]), rel=1e-6)
        thin = kirchhoff_wave_speeds(plate, f)
        assert speeds.phase < thin.phase and speeds.group < thin.group
    low, thin = (
        impedance.mindlin_wave_speeds(plate, 1.0),
        kirchhoff_wave_speeds(plate, 1.0),
    )
    assert low.phase == pytest.approx(thin.phase, rel=1e-3)
    assert low.group == pytest.approx(thin.group, rel=1e-3)
    assert thin.group == 2.0 * thin.phase


def test_fitted_transverse_shear_is_tied_to_the_through_thickness_modulus():
    # G_t = E_t / (2 (1 + nu)) with MDF's fitted E_t / E (no further parameter); materials
    # without a fitted surface have none to tie to.
    from synth.physics.materials import MDF_SURFACE, get, with_transverse_shear

    m = with_transverse_shear(get("mdf-18"))
    assert m.transverse_shear == pytest.approx(MDF_SURFACE.transverse_ratio * _G_ISO, rel=1e-15)
    with pytest.raises(ParameterError, match="fitted contact"):
        with_transverse_shear(get("steel"))


def test_mindlin_band_impedance():
    # 1 / <Re Y>: over 0-1 Hz the thin plate's Z_inf (the shear correction 4e-5 at 1 Hz);
    # over a narrow band 1 / Re Y at its middle (the band's curvature, 1e-6); over 0-10 kHz
    # of the isotropic 18 mm board 1327 N s/m (docs/physics.md, Thick plates; rounding).
    z_inf = impedance.infinite_plate_impedance(MDF18)
    assert mindlin_band_impedance(MDF18, 0.0, 1.0) == pytest.approx(z_inf, rel=1e-4)
    narrow = mindlin_band_impedance(SOFT18, 4999.0, 5001.0)
    assert narrow == pytest.approx(1.0 / impedance.mindlin_point_admittance(SOFT18, 5e3), rel=1e-6)
    assert mindlin_band_impedance(MDF18, 0.0, 1e4) == pytest.approx(1327.0, abs=0.5)
    with pytest.raises(ParameterError, match="high"):
        mindlin_band_impedance(MDF18, 2e3, 1e3)

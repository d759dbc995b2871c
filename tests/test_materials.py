"""Tests of synth.physics.materials: the built-in table, lookup, validation, damping laws."""

import dataclasses
import math
import re

import numpy as np
import pytest

from benchmarks.docs import table_markdown
from synth.errors import ParameterError
from synth.physics import materials
from synth.physics.materials import TABLE, LossFactor, Material, Rayleigh, get, names, resolve

NAME_RE = re.compile(r"^[a-z0-9]+(-[a-z0-9]+)*$")
BAD_REALS = [0.0, -1.0, float("nan"), float("inf"), float("-inf")]
NOT_NUMBERS = ["7800", None, True, [1.0], 1j]

# Rows a user expects to find (docs/physics.md, "Materials" and common handbook materials).
REQUIRED = [
    "mdf-18",
    "mdf-12",
    "mdf-6",
    "steel",
    "stainless-steel",
    "aluminium",
    "brass",
    "glass",
    "acrylic",
    "polycarbonate",
    "hardwood",
    "oak",
    "pine",
    "plywood",
    "concrete",
    "granite",
    "rubber",
    "abs",
    "porcelain",
]
# Names a user may type for rows listed under another name.
REQUIRED_ALIASES = {"ceramic": "porcelain", "pmma": "acrylic"}


# --------------------------------------------------------------------------- the table


@pytest.mark.parametrize("key", sorted(TABLE))
def test_table_row_is_valid(key):
    # Invariant: every row is a physically admissible, cited, well-named material.
    m = TABLE[key]
    assert m.name == key
    assert NAME_RE.match(key), key
    assert math.isfinite(m.density) and m.density > 0.0
    assert math.isfinite(m.young) and m.young > 0.0
    assert -1.0 < m.poisson < 0.5
    assert isinstance(m.damping, (Rayleigh, LossFactor))
    if isinstance(m.damping, LossFactor):
        assert 0.0 <= m.damping.eta < 1.0
    else:
        assert m.damping.alpha >= 0.0 and m.damping.beta >= 0.0
    assert isinstance(m.source, str) and len(m.source.strip()) > 10
    # E' = E / (1 - nu^2) by definition (docs/physics.md, "Materials"); relative 1e-15 is float
    # rounding.
    assert m.effective_modulus == pytest.approx(m.young / (1.0 - m.poisson**2), rel=1e-15)


@pytest.mark.parametrize("key", REQUIRED)
def test_required_rows_present(key):
    # The table must hold every required row, each with a loss factor or Rayleigh law.
    assert key in TABLE


@pytest.mark.parametrize("alias, row", sorted(REQUIRED_ALIASES.items()))
def test_required_aliases_name_rows(alias, row):
    # Common names reach their row: get(alias) is the row itself.
    assert get(alias) is TABLE[row]


def test_required_rows_present_rejects_unknown_name():
    # A name that is not a row is not silently accepted by the table lookup.
    with pytest.raises(ParameterError):
        get("unobtainium")


def test_names_sorted_and_complete():
    # names() is exactly the table's keys, sorted.
    assert names() == sorted(TABLE)
    assert len(names()) == len(TABLE) >= len(REQUIRED)


def test_thesis_rows_unchanged():
    # Published values, thesis Table 3.1 (docs/physics.md, "Materials"): exact, they are table
    # entries.
    expected = {
        "mdf-18": (700.0, 5.689e9, 0.4),
        "mdf-12": (700.0, 5.058e9, 0.4),
        "mdf-6": (700.0, 3.385e9, 0.4),
        "steel": (7800.0, 216e9, 0.3),
        "glass": (2480.0, 70e9, 0.2),
    }
    for key, (rho, e, nu) in expected.items():
        m = TABLE[key]
        assert (m.density, m.young, m.poisson) == (rho, e, nu)
    for key in ("mdf-18", "mdf-12", "mdf-6"):
        # MDF damping fit of docs/physics.md, "Materials".
        assert TABLE[key].damping == Rayleigh(35.0, 5e-7)


def test_steel_effective_modulus():
    # Closed form: E' = 216e9 / (1 - 0.3^2) = 216e9 / 0.91; 1e-12 relative is float rounding.
    assert TABLE["steel"].effective_modulus == pytest.approx(216e9 / 0.91, rel=1e-12)


def test_mdf_rayleigh_matches_handbook_loss_factor():
    # Published cross-check: the thesis' Rayleigh fit (35 1/s, 5e-7 s) as an equivalent loss
    # factor eta = 2 sigma / omega at 2.5 kHz (the band of the thesis' measured 11-14 ms decay)
    # is 0.0101; Hopkins (2007) Table A2 prints eta = 0.01 for MDF. Tolerance 2 %: the handbook
    # value has one significant figure, the fit two.
    omega = 2.0 * math.pi * 2500.0
    eta = 2.0 * float(TABLE["mdf-18"].damping.decay_rate(omega)) / omega
    assert eta == pytest.approx(0.01, rel=0.02)


def test_hopkins_rows_reproduce_printed_plate_speed_and_critical_frequency():
    # Hopkins Table A2 prints c_L (quasi-longitudinal plate speed) and h*f_c; the rows store
    # E = c_L^2 rho (1 - nu^2). Inverting must give c_L back (1e-12: float rounding), and
    # h f_c = c0^2 sqrt(12) / (2 pi c_L) with c0 = 343 m/s must match the printed product to
    # 1 % (printed to three figures).
    for key, c_l, hfc in (("plywood", 3850.0, 16.8), ("plasterboard", 1490.0, 43.5)):
        m = TABLE[key]
        speed = math.sqrt(m.young / (m.density * (1.0 - m.poisson**2)))
        assert speed == pytest.approx(c_l, rel=1e-12)
        assert 343.0**2 * math.sqrt(12.0) / (2.0 * math.pi * speed) == pytest.approx(hfc, rel=0.01)


def test_granite_reproduces_measured_wave_speeds():
    # Leet & Ewing (1932) measured c_P = 4.96 km/s and c_S = 2.48 km/s in Quincy granite and
    # derived E = 43e10 dyn/cm^2 (+-1), nu = 0.333, rho = 2650. The bulk wave speeds from the
    # row must match the measured ones within 2 % (E is printed to two figures, +-2.3 %,
    # i.e. +-1.2 % on a speed).
    m = TABLE["granite"]
    e, nu, rho = m.young, m.poisson, m.density
    c_p = math.sqrt(e * (1.0 - nu) / (rho * (1.0 + nu) * (1.0 - 2.0 * nu)))
    c_s = math.sqrt(e / (2.0 * rho * (1.0 + nu)))
    assert c_p == pytest.approx(4960.0, rel=0.02)
    assert c_s == pytest.approx(2480.0, rel=0.02)
    # Birch & Bancroft (1938): Q = 150, loss factor eta = 1/Q (exact by construction).
    assert m.damping.eta == pytest.approx(1.0 / 150.0, rel=1e-15)


def test_aluminium_bar_speed_matches_cremer():
    # Cremer et al. Table 4.3 prints c_LII = sqrt(E/rho) = 5200 m/s for aluminium (E 72 GPa,
    # rho 2700): the row must reproduce it within 1 % (the speed is printed to two figures).
    m = TABLE["aluminium"]
    assert math.sqrt(m.young / m.density) == pytest.approx(5200.0, rel=0.01)


def test_rubber_poisson_below_incompressible_limit():
    # nu = 0.5 is excluded by the model; the rubber row uses the handbook's 0.49.
    assert TABLE["rubber"].poisson == 0.49


# --------------------------------------------------------------------------- get / resolve


@pytest.mark.parametrize("spelling", ["steel", "STEEL", "Steel", "  steel ", "sTeEl\n"])
def test_get_is_case_insensitive(spelling):
    # Lookup ignores case and surrounding white space and returns the table's own object.
    assert get(spelling) is TABLE["steel"]


@pytest.mark.parametrize(
    "bad, hint",
    [("stel", "steel"), ("alumnium", "aluminium"), ("mdf18", "mdf-18"), ("plywod", "plywood")],
)
def test_get_rejects_unknown_name_with_suggestion(bad, hint):
    # An unknown name raises and suggests the nearest names (difflib).
    with pytest.raises(ParameterError, match="did you mean") as info:
        get(bad)
    assert repr(hint) in str(info.value)
    assert repr(bad) in str(info.value)


@pytest.mark.parametrize("bad", [3, None, 1.5, ["steel"]])
def test_get_rejects_non_string(bad):
    # A name must be a str: anything else is rejected, naming `material`.
    with pytest.raises(ParameterError, match="material"):
        get(bad)


def test_get_rejects_empty_string():
    # The empty name is not a row and is not matched to anything.
    with pytest.raises(ParameterError, match="not in the table"):
        get("")


def test_resolve_accepts_material_and_name():
    # A Material passes through unchanged (identity); a name resolves to the row.
    m = Material("custom", 1000.0, 1e9, 0.3)
    assert resolve(m) is m
    assert resolve("Glass") is TABLE["glass"]


@pytest.mark.parametrize("bad", [3, None, 2.0, ("steel",)])
def test_resolve_rejects_other_types(bad):
    # Neither a Material nor a str: rejected, the message names the caller's field.
    with pytest.raises(ParameterError, match="plate.material"):
        resolve(bad, "plate.material")


def test_resolve_rejects_unknown_name_naming_field():
    # The field name is prefixed to get()'s message, which still suggests 'steel'.
    with pytest.raises(ParameterError, match=r"ball\.material.*'steel'"):
        resolve("stel", "ball.material")


# --------------------------------------------------------------------------- Material


def test_material_builds_and_is_frozen():
    # Values are stored exactly as floats; the dataclass is immutable.
    m = Material("test", 1000, 2e9, 0.25, LossFactor(0.02), "hand made")
    assert (m.density, m.young, m.poisson) == (1000.0, 2e9, 0.25)
    assert isinstance(m.density, float)
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.density = 5.0


@pytest.mark.parametrize("field", ["density", "young"])
@pytest.mark.parametrize("bad", BAD_REALS)
def test_material_rejects_bad_positive_field(field, bad):
    # density and young must be finite and > 0: no clamping, the field is named.
    kwargs = dict(name="m", density=1000.0, young=1e9, poisson=0.3)
    kwargs[field] = bad
    with pytest.raises(ParameterError, match=rf"m\.{field}="):
        Material(**kwargs)


@pytest.mark.parametrize("field", ["density", "young", "poisson"])
@pytest.mark.parametrize("bad", NOT_NUMBERS)
def test_material_rejects_non_numbers(field, bad):
    # Strings, None, bools, sequences and complex numbers are not real numbers.
    kwargs = dict(name="m", density=1000.0, young=1e9, poisson=0.3)
    kwargs[field] = bad
    with pytest.raises(ParameterError, match=rf"m\.{field}="):
        Material(**kwargs)


@pytest.mark.parametrize("nu", [-0.999, -0.5, 0.0, 0.3, 0.499])
def test_material_accepts_poisson_inside_range(nu):
    # The open interval (-1, 0.5) is the isotropic stability range; values are kept exactly.
    assert Material("m", 1000.0, 1e9, nu).poisson == nu


@pytest.mark.parametrize("bad", [-1.0, 0.5, 0.7, -1.5, float("nan"), float("inf")])
def test_material_rejects_poisson_outside_range(bad):
    # Both ends are excluded: nu = 0.5 makes E' = E/(1-nu^2) finite but the
    # bulk modulus infinite, nu = -1 the shear modulus infinite.
    with pytest.raises(ParameterError, match=r"m\.poisson="):
        Material("m", 1000.0, 1e9, bad)


def test_material_without_damping_is_for_contacts_only():
    # A ball's material needs no damping law, nor a plate's for a contact; computing the
    # plate's modes does (they decay by it): the error names the missing law there.
    from synth.physics.modes import modes
    from synth.physics.scene import Ball, Plate

    m = Material("m", 1000.0, 1e9, 0.3)
    assert m.damping is None and Ball(m, 0.01).material is m
    plate = Plate(m, 0.002, 0.3, 0.2)
    with pytest.raises(ParameterError, match=r"plate\.material\.damping=None"):
        modes(plate, max_frequency=1000.0)


@pytest.mark.parametrize("bad", [0.01, "loss", (35.0, 5e-7), {"eta": 0.01}])
def test_material_rejects_bad_damping(bad):
    # The damping must be a Rayleigh or LossFactor object, not a bare number or tuple.
    with pytest.raises(ParameterError, match=r"m\.damping="):
        Material("m", 1000.0, 1e9, 0.3, bad)


@pytest.mark.parametrize("bad", ["", None, 5])
def test_material_rejects_bad_name(bad):
    # A material needs a non-empty string name (used in messages and presets).
    with pytest.raises(ParameterError, match="material.name"):
        Material(bad, 1000.0, 1e9, 0.3)


# --------------------------------------------------------------------------- damping laws


def test_rayleigh_decay_rate_closed_form():
    # sigma = alpha/2 + beta omega^2 / 2 (docs/physics.md, "Materials"); float rounding only.
    d = Rayleigh(35.0, 5e-7)
    omega = np.array([0.0, 1.0, 2.0 * math.pi * 100.0, 2.0 * math.pi * 1e4])
    sigma = d.decay_rate(omega)
    assert sigma.shape == omega.shape
    np.testing.assert_allclose(sigma, 17.5 + 2.5e-7 * omega**2, rtol=1e-15, atol=0.0)
    # At omega = 0 only the mass term is left: sigma = alpha / 2 = 17.5 1/s.
    assert float(d.decay_rate(0.0)) == 17.5


def test_loss_factor_decay_rate_closed_form():
    # sigma = eta omega / 2; at 1 kHz with eta = 1e-3 this is pi 1/s, i.e. a 60 dB decay time
    # T60 = 3 ln(10) / sigma = 2.199 s. Tolerance: float rounding.
    d = LossFactor(1e-3)
    omega = 2.0 * math.pi * 1000.0
    sigma = float(d.decay_rate(omega))
    assert sigma == pytest.approx(math.pi, rel=1e-14)
    assert 3.0 * math.log(10.0) / sigma == pytest.approx(2.198806796638, rel=1e-12)
    omegas = np.linspace(0.0, 1e5, 7)
    np.testing.assert_allclose(d.decay_rate(omegas), 5e-4 * omegas, rtol=1e-15, atol=0.0)


@pytest.mark.parametrize(
    "alpha, beta, field",
    [
        (-1.0, 0.0, "damping.alpha"),
        (float("nan"), 0.0, "damping.alpha"),
        (float("inf"), 0.0, "damping.alpha"),
        ("35", 0.0, "damping.alpha"),
        (0.0, -1e-9, "damping.beta"),
        (0.0, float("nan"), "damping.beta"),
        (0.0, float("inf"), "damping.beta"),
        (0.0, None, "damping.beta"),
    ],
)
def test_rayleigh_rejects_bad_coefficients(alpha, beta, field):
    # alpha (1/s) and beta (s) must be finite and >= 0; the message names the coefficient.
    with pytest.raises(ParameterError, match=re.escape(field)):
        Rayleigh(alpha, beta)


def test_rayleigh_accepts_zero():
    # Zero damping is allowed (lossless limit), not clamped.
    assert Rayleigh(0.0, 0.0).decay_rate(1000.0) == 0.0


@pytest.mark.parametrize("bad", [-1e-6, 1.0, 1.5, float("nan"), float("inf"), "0.1", None])
def test_loss_factor_rejects_bad_eta(bad):
    # eta must be finite and in [0, 1); 1 itself is excluded.
    with pytest.raises(ParameterError, match="damping.eta"):
        LossFactor(bad)


@pytest.mark.parametrize("eta", [0.0, 1e-6, 0.5, 0.999])
def test_loss_factor_accepts_range(eta):
    # The closed lower end and values just below 1 are accepted and stored exactly.
    assert LossFactor(eta).eta == eta


# --------------------------------------------------------------------------- table_markdown


def test_table_markdown_lists_every_row():
    # One Markdown line per table row, in name order, whose numbers round-trip to the row.
    text = table_markdown()
    lines = text.strip().split("\n")
    # Header, separator, then one line per row in name order.
    assert len(lines) == 2 + len(TABLE)
    assert lines[0].startswith("| name | density")
    for line, key in zip(lines[2:], names()):
        cells = [c.strip() for c in line.strip("|").split(" | ")]
        assert cells[0] == key
        m = TABLE[key]
        # Density and modulus as printed round-trip to 4 significant figures.
        assert float(cells[1]) == pytest.approx(m.density, rel=1e-4)
        assert float(cells[2]) * 1e9 == pytest.approx(m.young, rel=5e-4)
        assert float(cells[3]) == pytest.approx(m.poisson, rel=1e-6)
        assert cells[5]  # a non-empty source


def test_table_markdown_rejects_pipe_breaking_rows():
    # A '|' inside a source must be escaped, or it would split the Markdown row.
    text = table_markdown()
    for line in text.strip().split("\n")[2:]:
        assert line.replace("\\|", "").count("|") == 7


@pytest.mark.parametrize(
    "alias, row",
    [
        ("ceramic", "porcelain"),
        ("PMMA", "acrylic"),
        ("aluminum", "aluminium"),
        ("stainless", "stainless-steel"),
    ],
)
def test_aliases_name_table_rows(alias, row):
    # an alias is the same row, not a copy
    assert materials.get(alias) is materials.get(row)


def test_aliases_rejects_unknown_alias():
    with pytest.raises(ParameterError, match="ceramik"):
        materials.get("ceramik")


@pytest.mark.parametrize(
    "field, inside, outside, reason",
    [
        ("young", (100.0, 1.21e12), (99.0, 1.3e12, 1e308, 1e-300), "elastomers to diamond"),
        ("density", (0.16, 22_590.0), (0.1, 22_600.0, 1e308, 1e-300), "aerogel to osmium"),
    ],
)
def test_material_constants_lie_in_the_range_of_real_solids(field, inside, outside, reason):
    # Young's modulus from the softest elastomers (about 100 Pa) to diamond (1.21 TPa),
    # density from graphene aerogel (0.16 kg/m^3) to osmium (22 590 kg/m^3): the ends are
    # accepted as given, a value beyond is refused naming the field, the value, the
    # interval and why (the table's materials all lie inside).
    from synth.physics.materials import DENSITY_RANGE, YOUNG_RANGE

    bounds = {"young": YOUNG_RANGE, "density": DENSITY_RANGE}[field]
    assert bounds == inside
    kwargs = dict(name="m", density=1000.0, young=1e9, poisson=0.3)
    for value in inside:
        assert getattr(Material(**{**kwargs, field: value}), field) == value
    for value in outside:
        with pytest.raises(ParameterError) as info:
            Material(**{**kwargs, field: value})
        text = str(info.value)
        assert f"m.{field}={value!r}" in text and f"[{inside[0]:g}, {inside[1]:g}]" in text
        assert reason in text
    for name in names():
        assert bounds[0] <= getattr(get(name), field) <= bounds[1]

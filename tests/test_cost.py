"""The cost estimate's memory (synth.cost.MemoryParts) against what a render allocates.

A cold render (a private disk cache, the memory caches cleared) is traced with
tracemalloc; its peak of traced allocations must lie below the estimate, and the
estimate within MEMORY_FACTOR of it. The scenes are ones where the sized arrays
dominate (each part of the estimate in turn: the Rayleigh sums' chunks, the Ritz
solver, the audio, the impacts' modal amplitudes), not the interpreter's fixed
overhead (well under 1 MiB), which the estimate leaves out. Arrays allocated inside
numba kernels are not traced.
"""

from __future__ import annotations

import copy
import tracemalloc

import pytest

from benchmarks.cost import rule_counts
from synth import cost
from synth.io.presets import find, read, scene_from_dict
from synth.sound.radiation.rules import PolarRule, SummedRule, rule_weights, weighted_counts
from synth.sound.render import render

#: How far above the traced peak the estimate may lie: it counts every chunk the
#: Rayleigh sums may hold (synth.cost.RADIATION_CHUNKS) and the solver's full LAPACK
#: workspace, which a given scene need not use at once.
MEMORY_FACTOR = 4.0

SMALL = {
    "ball": {"material": "steel", "radius": 0.005},
    "plate": {"material": "mdf-18", "thickness": 0.018, "length": 0.3, "width": 0.2,
              "boundary": "simply-supported"},
    "drop": {"height": 0.02, "position": [0.15, 0.1]},
    "listener": {"type": "microphone", "position": [0.15, 0.1, 0.2]},
    "render": {"samplerate": 16000, "max_frequency": 4000.0, "max_duration": 0.3,
               "max_tail": 0.3},
}  # fmt: skip


def _variant(base: dict, **changes) -> dict:
    data = copy.deepcopy(base)
    for key, value in changes.items():  # section__field = value, or section = table
        section, _, field = key.partition("__")
        if field:
            data[section][field] = value
        else:
            data[section] = value
    return data


def _default(**changes) -> dict:
    return _variant(read(find("default")), **changes)


SHEET = dict(
    plate__material="steel", plate__thickness=0.001, plate__length=1.0, plate__width=0.8,
    drop__position=[0.4, 0.3],
)  # fmt: skip

SCENES = {
    # a simply supported sheet's ~1000 modes heard by a microphone: the sums' chunks
    "radiation-chunks": _variant(SMALL, listener__position=[0.4, 0.3, 0.3], **SHEET),
    # the free board (Ritz modes) heard by a microphone
    "free-board-microphone": _default(
        render={"samplerate": 32000, "max_frequency": 8000.0, "max_duration": 1.0, "max_tail": 1.0},
    ),  # fmt: skip
    # the free board's cold Ritz solve of ~430 unknowns
    "free-board-solver": _default(
        listener={"type": "accelerometer", "position": [0.3, 0.2]},
        render={
            "samplerate": 24000,
            "max_frequency": 12000.0,
            "max_duration": 1.0,
            "max_tail": 1.0,
        },
    ),  # fmt: skip
    # a long ring-down of a glass plate: the audio
    "long-audio": _variant(
        SMALL,
        plate__material="glass",
        plate__thickness=0.006,
        listener__type="accelerometer",
        listener__position=[0.1, 0.05],
        render__max_duration=5.0,
        render__max_tail=60.0,
        render__floor_db=-120.0,
    ),  # fmt: skip
    # a steel ball bouncing on a steel plate, heard by an accelerometer: the impacts'
    # modal amplitudes and the per-mode vectors beside the audio
    "bounces": _variant(
        SMALL,
        plate__material="steel",
        plate__thickness=0.002,
        plate__length=1.2,
        plate__width=0.9,
        drop__height=0.3,
        drop__position=[0.4, 0.3],
        listener__type="accelerometer",
        listener__position=[0.3, 0.2],
        render__max_frequency=8000.0,
        render__max_duration=10.0,
        render__max_tail=0.5,
    ),  # fmt: skip
}


def _clear_memory_caches() -> None:
    from synth.physics import modes
    from synth.physics.modal_contact import point
    from synth.sound import radiation

    modes.clear_memory_cache()
    radiation.clear_memory_cache()
    point.clear_memory_cache()


def _estimate(scene, options) -> cost.CostEstimate:
    keys = ("max_frequency", "preroll", "max_duration", "max_tail", "pulse_points", "floor_db")
    return cost.estimate(
        scene, samplerate=options["samplerate"], **{k: options[k] for k in keys if k in options}
    )


@pytest.fixture(scope="module")
def warm():
    """Every kernel and module a render uses loaded once (their first use allocates
    objects of the interpreter that no scene's size sets), the bounces' on a thin steel
    plate too (a narrower band of that scene: else the first use of its contact's code
    counts in the peak traced when it runs first)."""
    for data in (
        _variant(SCENES["bounces"], render__max_frequency=2000.0),
        SMALL,
        _variant(
            SMALL,
            listener__type="accelerometer",
            listener__position=[0.1, 0.05],
            plate__boundary="free",
        ),
    ):
        scene, options = scene_from_dict(data, "warm-up")
        options.pop("subtype", None)
        render(scene, **options)  # fmt: skip


@pytest.mark.parametrize("name", sorted(SCENES))
def test_memory_estimate_bounds_the_traced_peak(name, warm, tmp_path, monkeypatch):
    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path))  # cold: modes and gains solved
    if name == "radiation-chunks":  # the rectangle rule's chunks, which the estimate holds
        from synth.sound.radiation.rules import RectangleRule

        monkeypatch.setattr("synth.sound.radiation.rules.RULES", (RectangleRule(),))
    _clear_memory_caches()
    scene, options = scene_from_dict(SCENES[name], name)
    options.pop("subtype", None)
    estimate = _estimate(scene, options)
    tracemalloc.start()
    try:
        render(scene, **options)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
        _clear_memory_caches()
    parts = {k: round(v / 2**20, 3) for k, v in vars(estimate.memory).items()}
    assert peak <= estimate.memory_bytes <= MEMORY_FACTOR * peak, (
        f"{name}: traced peak {peak / 2**20:.2f} MiB, estimate "
        f"{estimate.memory_bytes / 2**20:.2f} MiB ({parts})"
    )


def test_memory_parts_follow_the_code_sizes():
    # The radiation part is there for a microphone only and is at most the chunks the
    # sums hold; the solver's part is SOLVER_SQUARES dense squares of its largest main
    # basis (a simply supported plate has none: closed-form modes).
    from synth.physics.modes import solver_sizes
    from synth.sound.radiation.common import CHUNK_BYTES

    for name, data in SCENES.items():
        scene, options = scene_from_dict(data, name)
        est = _estimate(scene, options)
        mic = data["listener"]["type"] == "microphone"
        assert (est.memory.radiation > 0) == mic
        assert est.memory.radiation <= cost.RADIATION_CHUNKS * CHUNK_BYTES
        main, check = solver_sizes(scene.plate, est.max_frequency)
        squares = max(cost.SOLVER_SQUARES * max(main, default=0) ** 2,
                      cost.CHECK_SQUARES * max(check, default=0) ** 2)  # fmt: skip
        assert est.memory.solver == 8 * squares
        assert est.memory_bytes == est.memory.total


def test_memory_beyond_the_budget_is_refused_naming_its_largest_part():
    from synth.errors import ParameterError

    scene, options = scene_from_dict(SCENES["radiation-chunks"], "radiation-chunks")
    est = _estimate(scene, options)
    assert est.memory.radiation == max(vars(est.memory).values())
    with pytest.raises(ParameterError, match=r"most of it the radiation.*SYNTH_MAX_MEMORY_BYTES"):
        est.check(cost.Budget(max_memory_bytes=est.memory_bytes - 1))
    est.check(cost.Budget(max_memory_bytes=est.memory_bytes))


# ----------------------------------------------------------------- the radiation stage

#: Free plates (Ritz shapes) and a narrow strip beside the small simply supported one:
#: the radiation part of the estimate (synth.cost.RadiationWork) on each kind of shape.
RADIATION_SCENES = {
    "simply-supported": SMALL,
    "free-plate": _variant(SMALL, plate__boundary="free", plate__material="aluminium",
                           plate__thickness=0.003),
    "free-strip": _variant(SMALL, plate__boundary="free", plate__material="steel",
                           plate__thickness=0.002, plate__length=0.8, plate__width=0.01,
                           drop__position=[0.4, 0.005], listener__position=[0.4, 0.005, 0.2]),
}  # fmt: skip


def _rule_ratio(rules: int) -> float:
    """How far the estimate's points may lie above a refinement that stops at its first
    refinement (the fewest rules the convergence test takes): ``sum_l REFINE^(2 l)`` over
    ``rules`` rules against the first two."""
    from synth.sound.radiation.common import REFINE

    return sum(REFINE ** (2 * level) for level in range(rules)) / (1 + REFINE**2)


def _measured_sums(monkeypatch) -> list:
    """(points, modes) of every rule the rectangle rule's sums evaluate from now on."""
    from synth.sound.radiation import rectangle

    calls, original = [], rectangle.apply_rule

    def counted(shape_fn, grid, listener, r_mid, poles, chunk):
        calls.append((grid.xs.size * grid.ys.size, poles.qr.size))
        return original(shape_fn, grid, listener, r_mid, poles, chunk)

    monkeypatch.setattr(rectangle, "apply_rule", counted)
    return calls


@pytest.mark.parametrize("name", sorted(RADIATION_SCENES))
@pytest.mark.parametrize("cut", [False, True], ids=["budget", "cut"])
def test_radiation_estimate_bounds_the_sums_measured(name, cut, tmp_path, monkeypatch):
    # A cold render's rectangle-rule sums, counted: their points (summed over the rules
    # the refinement took) lie at or below the estimate's, which counts every rule the
    # budget allows, and the estimate within _rule_ratio of them (times 2: the render's
    # wavenumber is its highest mode's, at or below the band's top, and a rule's points
    # grow as its square). With a budget that holds only the first rule and one
    # refinement the render takes no more (the refinement is cut there, and says so).
    import warnings

    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path))
    _clear_memory_caches()
    scene, options = scene_from_dict(RADIATION_SCENES[name], name)
    options.pop("subtype", None)
    full = _estimate(scene, options)
    assert full.radiation.rule == "rectangle" and full.radiation.max_points is None
    budget = cost.Budget()
    if cut:  # the first two rules' work, and less than the third's
        budget = cost.Budget(max_radiation_work=int(full.radiation.work_of(2)) + 1)
    est = cost.estimate(scene, samplerate=options["samplerate"], budget=budget,
                        **{k: options[k] for k in ("max_frequency", "preroll", "max_duration",
                                                   "max_tail", "pulse_points", "floor_db")
                           if k in options})  # fmt: skip
    calls = _measured_sums(monkeypatch)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a cut refinement warns
        render(scene, budget=budget, **options)
    _clear_memory_caches()
    points = sum(n for n, _ in calls)
    r = est.radiation
    assert len(calls) <= r.rules and (r.rules == 2) == cut
    assert points <= r.points <= 2.0 * _rule_ratio(r.rules) * points, (name, calls, r)
    assert r.work == r.evaluations * (1 + r.shape_terms) == r.work_of(r.rules)


# ------------------------------------------------------------- the other radiation rules

#: Each of the other rules on a small scene, the only rule choose_rule may take (the list
#: the estimate and the render both choose from, synth.sound.radiation.rules.RULES): the
#: simply supported sheet for the polar rule and the free aluminium plate for the summed one.
RULE_SCENES = {
    "polar": (SCENES["radiation-chunks"], {"synth.sound.radiation.rules.RULES": (PolarRule(),)}),
    "summed": (
        RADIATION_SCENES["free-plate"],
        {"synth.sound.radiation.rules.RULES": (SummedRule(),)},
    ),
}

#: How far above the counted points of a rule the estimate's may lie: it takes the
#: wavenumbers of the band's top (the render its highest mode's, at or below it).
POINTS_FACTOR = 1.25
#: How far above the counted work of the rules a render took the estimate's may lie:
#: besides POINTS_FACTOR, each rule counts every mode where a selective refinement
#: evaluates only those still failing.
WORK_FACTOR = 3.0


def _counted_rules(name, monkeypatch) -> list:
    """Per rule the render applies, from now on: [points, work] counted from the rule's
    own arguments with the term weights of synth.sound.radiation.rules."""
    import numpy as np

    from synth.sound.radiation import polar
    from synth.sound.radiation import rules as w

    levels = []
    attr = "_apply_separable_rule" if name == "polar" else "_apply_summed_rule"
    original = getattr(polar, attr)

    def counted(shapes, setup, radii, *rest):
        active = rest[-1]
        total, angular = original(shapes, setup, radii, *rest)
        if name == "polar":
            n_x = np.unique(shapes.x_index[active]).size
            n_y = np.unique(shapes.y_index[active]).size
            per_mode = w.POLAR_RADIAL_TERMS
        else:
            n_x, n_y = shapes.n_x, shapes.n_y
            per_mode = 1 + max(coef.shape[0] for _, _, coef in shapes._parts)
        terms = angular * (n_x + n_y + n_x * n_y) + radii.size * active.size * per_mode
        levels.append([angular, float(terms)])
        return total, angular

    monkeypatch.setattr(polar, attr, counted)
    return levels


@pytest.mark.parametrize("name", sorted(RULE_SCENES))
@pytest.mark.parametrize("cut", [False, True], ids=["budget", "cut"])
def test_each_rules_estimate_bounds_its_counted_work(name, cut, tmp_path, monkeypatch):
    # A cold render by the polar or the summed rule, each rule it applies counted (its
    # angular points, and its work by the same term weights on the real factors and
    # modes): the estimate of each
    # rule lies at or above the count and within POINTS_FACTOR of it, its work within
    # WORK_FACTOR. With a budget that holds only the first rule and one refinement the
    # render takes no more (the estimate's max_points stops it there).
    import warnings

    data, lowered = RULE_SCENES[name]
    for target, value in lowered.items():
        monkeypatch.setattr(target, value)
    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path))
    _clear_memory_caches()
    scene, options = scene_from_dict(data, name)
    options.pop("subtype", None)
    full = _estimate(scene, options)
    assert full.radiation.rule == name and full.radiation.max_points is None, full.radiation
    budget = cost.Budget()
    if cut:
        budget = cost.Budget(max_radiation_work=int(full.radiation.work_of(2)) + 1)
    est = cost.estimate_render(scene, options, budget)
    r = est.radiation
    levels = _counted_rules(name, monkeypatch)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a cut refinement warns
        render(scene, budget=budget, **options)
    _clear_memory_caches()
    assert 2 <= len(levels) <= r.rules and (r.rules == 2) == cut, (levels, r)
    for level, (points, _) in enumerate(levels):
        assert points <= r.rule_points[level] <= POINTS_FACTOR * points, (level, levels, r)
    work = sum(terms for _, terms in levels)
    # the estimate's work is in rectangle-term equivalents: back to the rule's own terms
    estimated = (r.work_of(len(levels)) - r.fixed_work) / rule_weights()[name]
    assert work <= estimated <= WORK_FACTOR * work, (levels, r)


def test_the_estimates_rule_is_the_one_plate_gains_takes_with_its_max_points():
    # The estimate and plate_gains choose by one function (choose_rule), which excludes a
    # rule whose check rule exceeds max_points: for two steel sheets past the crossover
    # (5 x 5 m to 6 kHz, 3 x 3 m to 24 kHz) under radiation budgets that hold at least two
    # rules, the estimate's rule is the one choose_rule takes with the estimate's
    # max_points (a cut never below the rule's check rule: it keeps the rule; nothing
    # solved).
    from synth import Microphone, Plate
    from synth.sound import radiation as rad
    from synth.sound.radiation.rules import choose_rule

    seen = set()
    for side, f_max in ((5.0, 6000.0), (3.0, 24000.0)):
        plate = Plate("steel", thickness=0.001, length=side, width=side)
        microphone = Microphone((side / 2, side / 2, 0.3))
        modes = cost.modal_count(plate, f_max)
        for work in (1e10, 1e11, 1e12, 1e13):
            budget = cost.Budget(max_radiation_work=int(work))
            r = cost.radiation_work(plate, microphone, modes, f_max, budget)
            if r.rules < 2:
                continue  # refused: nothing runs
            max_points = rad.DEFAULT_MAX_POINTS if r.max_points is None else r.max_points
            problem = cost.estimates.radiation_problem(plate, microphone, modes, f_max, max_points)
            chosen = choose_rule(problem)
            assert r.rule == chosen.rule.name and chosen.fits, (side, work, r.rule, max_points)
            seen.add(r.rule)
    assert seen == {"banded"}


STRIP = _default(
    plate={"material": "steel", "thickness": 0.0005, "length": 5.0, "width": 0.001,
           "boundary": "free"},
    ball={"material": "steel", "radius": 0.0004},
    drop={"height": 0.1, "position": [2.5, 0.0005]},
)  # fmt: skip


def test_the_long_thin_strip_is_refused_or_cut_before_any_work():
    # The 5 m x 1 mm steel strip, 0.5 mm thick, heard by the default microphone: its
    # Ritz shapes cost ~560 terms per mode and point, and its sums refine to their last
    # rule (measured: 577 297 points in 7 rules; the estimate's count of the first rules
    # is the same function of the panels). The default budget cuts the refinement before
    # the last rule; a budget below its first two rules refuses it naming the budget,
    # what is too big and what to change.
    from synth.errors import ParameterError
    from synth.sound.radiation.common import MAX_RULES

    scene, options = scene_from_dict(STRIP, "strip")
    est = _estimate(scene, options)
    r = est.radiation
    assert r.rule == "rectangle" and r.shape_terms > 100
    assert 2 <= r.rules < MAX_RULES and r.max_points is not None
    assert r.work <= cost.DEFAULT_MAX_RADIATION_WORK
    small = cost.Budget(max_radiation_work=int(r.work / 20))
    refused = cost.estimate(scene, samplerate=options["samplerate"], budget=small)
    says = r"Rayleigh sums need .* first rule and one refinement.*SYNTH_MAX_RADIATION_WORK.*accel"
    with pytest.raises(ParameterError, match=says):
        refused.check(small)


#: The 3 x 3 m, 1 mm steel sheet heard from 0.3 m above its centre to 24 kHz: past the
#: Ritz crossover, its edge effect modes take the banded rule.
SHEET = dict(side=3.0, thickness=0.001, max_frequency=24000.0)


def _sheet():
    """(plate, microphone, modes, f_max) of SHEET."""
    from synth import Microphone, Plate

    side, f_max = SHEET["side"], SHEET["max_frequency"]
    plate = Plate("steel", thickness=SHEET["thickness"], length=side, width=side)
    return plate, Microphone((side / 2, side / 2, 0.3)), cost.modal_count(plate, f_max), f_max


def _shipped_weights() -> dict:
    """The rectangle rule's rate over each rule's, read from the shipped rates file."""
    import json

    rates = json.loads(cost.RATES.read_text())["radiation_terms_per_second"]
    return {rule: rates["rectangle"] / rate for rule, rate in rates.items()}


def test_each_rules_work_is_its_terms_times_its_weight_from_the_shipped_rates():
    # The budget counts a rule's terms in rectangle-term equivalents: its terms times the
    # rectangle rule's rate over its own, both from the rates file shipped with the package
    # (so the same on every machine); the rectangle rule's weight is 1. For each rule's
    # counts of the 3 x 3 m sheet, the weighted work is the counted terms times that ratio
    # (to rounding: one product); the estimate's radiation work is the weighted counts.
    plate, microphone, modes, f_max = _sheet()
    weights = _shipped_weights()
    assert rule_weights() == pytest.approx(weights, rel=1e-15)
    assert rule_weights()["rectangle"] == 1.0
    counts = rule_counts("banded", plate, microphone, modes, f_max)
    weighted = weighted_counts(counts)
    assert weighted.work == pytest.approx([w * weights["banded"] for w in counts.work], rel=1e-15)
    assert weighted.fixed == pytest.approx(counts.fixed * weights["banded"], rel=1e-15)
    assert weighted.points == counts.points
    r = cost.radiation_work(plate, microphone, modes, f_max, cost.Budget(max_radiation_work=10**14))
    counts = weighted_counts(rule_counts(r.rule, plate, microphone, modes, f_max))
    assert r.rule == "banded" and r.rule_work == counts.work and r.fixed_work == counts.fixed


def test_a_rectangle_rules_cut_is_that_of_its_terms():
    # The rectangle rule weighs 1: the long strip's cut (the most rules whose summed terms
    # fit the default budget, the refinement stopped at the last one's points) is that of
    # its unweighted counts.
    from synth.physics.modes import shape_terms
    from synth.sound.radiation.common import MAX_RULES

    scene, options = scene_from_dict(STRIP, "strip")
    f_max = _estimate(scene, options).max_frequency
    modes = cost.modal_count(scene.plate, f_max)
    r = cost.radiation_work(scene.plate, scene.listener, modes, f_max, cost.Budget())
    counts = rule_counts("rectangle", scene.plate, scene.listener, modes, f_max)
    fits = [
        n for n in range(2, MAX_RULES + 1)
        if counts.fixed + sum(counts.work[:n]) <= cost.DEFAULT_MAX_RADIATION_WORK
    ]  # fmt: skip
    assert r.rule == "rectangle" and r.shape_terms == shape_terms(scene.plate, f_max)
    assert r.rule_work == counts.work and r.rules == max(fits) < MAX_RULES
    assert r.max_points == counts.points[r.rules - 1]


def test_every_shipped_preset_keeps_four_radiation_rules_within_the_default_budget():
    # The default budget cuts the sums' refinement only past the fourth rule for every
    # shipped preset at 48 kHz (so their converged gains, none of which needs more, are
    # those of the full refinement), and refuses none of them.
    from synth.io.presets import available

    for name, path in sorted(available().items()):
        scene, options = scene_from_dict(read(path), name)
        options["samplerate"] = 48000
        options["max_frequency"] = None
        est = _estimate(scene, options)
        r = est.radiation
        assert r.rule != "rectangle" or r.rules >= 4, (name, r)
        assert not est.excess(cost.Budget()), name


# ------------------------------------------------------------------- time in seconds


def test_the_estimated_time_is_the_work_over_the_measured_rates(tmp_path):
    # synth info --cost turns the solver's operations and the radiation rule's terms into
    # seconds by the rates synth bench cost measured (synth.cost.Rates): the time is their
    # quotient, exactly, from the radiation's first two rules (the fewest a refinement takes)
    # to every rule the budget holds; without measured rates the row says how to measure
    # them. No clock is read here.
    import json

    path = tmp_path / "rates.json"
    path.write_text(json.dumps({
        "solver_flops_per_second": 1e10,
        "radiation_terms_per_second": {"rectangle": 2e9, "polar": 1e9, "summed": 1e9,
                                       "banded": 1e9},
        "measured": "a test",
    }))  # fmt: skip
    rates = cost.Rates.load(path)
    scene, options = scene_from_dict(RADIATION_SCENES["free-plate"], "free-plate")
    est = _estimate(scene, options)
    solver, fewest, most = rates.seconds(est)
    r = est.radiation
    assert solver == est.solver_flops / 1e10 and most == r.work / 2e9 and r.rules > 2
    assert fewest == r.work_of(2) / 2e9 < most
    name, text = cost.time_row(est, rates)
    assert f"{solver + fewest:.3g} to {solver + most:.3g} s" in text and "a test" in text
    assert "synth bench cost --record" in cost.time_row(est, None)[1]
    assert cost.Rates.load(tmp_path / "absent.json") is None


def test_the_shipped_rates_cover_every_rule():
    # The rates file synth bench cost --record writes beside synth.cost, shipped in the wheel,
    # names a positive rate for the mode solver and for every radiation rule the estimate may
    # take: without it the estimates fall back to bounds (a packaging fault, not a skip).
    rates = cost.Rates.load()
    assert rates is not None, "synth/cost_rates.json missing from the installed package"
    assert rates.solver > 0 and rates.measured.startswith("synth bench cost")
    assert set(rates.radiation) == {"rectangle", "polar", "summed", "banded"}
    assert all(v > 0 for v in rates.radiation.values())

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

from synth import cost
from synth.io.presets import find, read, scene_from_dict
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
    from synth.physics.modal_contact import point
    from synth.sound import modes, radiation

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
    objects of the interpreter that no scene's size sets)."""
    for data in (
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
    from synth.sound.modes import solver_sizes
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

    def counted(shape_fn, xs, wx, ys, wy, listener, q, *rest):
        calls.append((xs.size * ys.size, q.size))
        return original(shape_fn, xs, wx, ys, wy, listener, q, *rest)

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
        budget = cost.Budget(max_radiation_work=int(full.radiation.work_of(2, full.modes)) + 1)
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
    assert r.work == r.evaluations * (1 + r.shape_terms) == r.work_of(r.rules, est.modes)


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

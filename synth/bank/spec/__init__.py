"""Bank specs: a TOML file describing many variations of one preset, and their plan.

Every key of a spec (only ``preset`` is required), how its rows are drawn and named:
docs/banks.md, "Every key of a spec". A variation's ranges come from its own generator
``numpy.random.default_rng([seed, i])`` and its lists' combinations are drawn block by
block (:class:`_ListDraws`), so a row does not depend on the count or on the rows after
it: raising ``count`` adds rows. ``restitution_scale`` is the one key that is not a preset
key: the impacts are :func:`synth.stimuli.sequences.scaled_sequence` of the scene (thesis
section 5.2.2). Tags, labels, the preset's name and the name template change no sound: a
bank resumes across a change of them (:func:`compared_form`).

A spec that cannot be run is a :class:`BankSpecError` naming the key, its value and what is
allowed, raised before any work (the first scene is built too).

Modules: :mod:`~synth.bank.spec.model` (the record, its keys and forms),
:mod:`~synth.bank.spec.loading` (reading and checking a spec),
:mod:`~synth.bank.spec.sampling` (its variations), :mod:`~synth.bank.spec.naming` (labels
and file names) and :mod:`~synth.bank.spec.planning` (the plan).
"""

from __future__ import annotations

from synth.bank.spec.loading import PACKAGE_BANKS, available, find, from_dict, load
from synth.bank.spec.model import (
    BANK_MAX_IMPACTS,
    DEFAULT_NORMALIZE,
    ENGINE,
    FORMATS,
    MAX_ROWS,
    NOT_AUDIO,
    PLAN_VERSION,
    RENDER_DEFAULTS,
    RESTITUTION_SCALE,
    TOP_LEVEL,
    TRIM_DEFAULTS,
    BankSpec,
    BankSpecError,
    ListAxis,
    RangeAxis,
    canonical,
    compared_form,
)
from synth.bank.spec.naming import MAX_NAME_BYTES, file_name, row_labels
from synth.bank.spec.planning import (
    ROWS_NAMED,
    PlanItem,
    check_rows,
    differences,
    parse_rows,
    plan,
    row_problem,
    scene_data,
)
from synth.bank.spec.sampling import (
    LHS_BLOCK,
    MIN_DISTANCE_ATTEMPTS,
    MIN_DISTANCE_MAX_ROWS,
    PERMUTED_COMBINATIONS,
    SAMPLINGS,
    RepeatedRowsWarning,
    variations,
)

__all__ = [
    "BANK_MAX_IMPACTS",
    "BankSpec",
    "BankSpecError",
    "DEFAULT_NORMALIZE",
    "ENGINE",
    "FORMATS",
    "LHS_BLOCK",
    "ListAxis",
    "MAX_NAME_BYTES",
    "MAX_ROWS",
    "MIN_DISTANCE_ATTEMPTS",
    "MIN_DISTANCE_MAX_ROWS",
    "NOT_AUDIO",
    "PACKAGE_BANKS",
    "PERMUTED_COMBINATIONS",
    "PLAN_VERSION",
    "PlanItem",
    "RENDER_DEFAULTS",
    "RESTITUTION_SCALE",
    "ROWS_NAMED",
    "RangeAxis",
    "RepeatedRowsWarning",
    "SAMPLINGS",
    "TOP_LEVEL",
    "TRIM_DEFAULTS",
    "available",
    "canonical",
    "check_rows",
    "compared_form",
    "differences",
    "file_name",
    "find",
    "from_dict",
    "load",
    "parse_rows",
    "plan",
    "row_labels",
    "row_problem",
    "scene_data",
    "variations",
]

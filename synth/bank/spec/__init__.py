"""Bank specs: a TOML file describing many variations of one preset, and their plan
(docs/banks.md, "Every key of a spec").

Each row's ranges come from its own generator ``numpy.random.default_rng([seed, i])`` and
list combinations are drawn block by block (:class:`_ListDraws`), so raising ``count`` only
adds rows. ``restitution_scale`` scales the impacts
(:func:`synth.stimuli.sequences.scaled_sequence`); tags, labels, the preset's name and the
name template change no sound (:func:`compared_form`). A spec that cannot be run is a
:class:`BankSpecError` naming the key, its value and what is allowed, before any work.
Modules: :mod:`~.model`, :mod:`~.loading`, :mod:`~.sampling`, :mod:`~.naming`,
:mod:`~.planning`.
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

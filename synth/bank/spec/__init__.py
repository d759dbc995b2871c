"""Bank specs: a TOML file describing many variations of one preset, and their plan
(docs/banks.md, "Every key of a spec"). Each row draws from its own generator
``default_rng([seed, i])``, so raising ``count`` only adds rows; a spec that cannot be run is
a :class:`BankSpecError` naming the key, its value and what is allowed, before any work."""

from __future__ import annotations

from synth.bank.spec.loading import from_dict, load
from synth.bank.spec.model import (
    BANK_MAX_IMPACTS,
    ENGINE,
    FORMATS,
    MAX_ROWS,
    RESTITUTION_SCALE,
    BankSpec,
    BankSpecError,
    canonical,
    compared_form,
)
from synth.bank.spec.naming import row_labels
from synth.bank.spec.planning import PlanItem, differences, parse_rows, plan, scene_data
from synth.bank.spec.sampling import LHS_BLOCK, PERMUTED_COMBINATIONS, RepeatedRowsWarning

__all__ = [
    "BANK_MAX_IMPACTS",
    "BankSpec",
    "BankSpecError",
    "ENGINE",
    "FORMATS",
    "LHS_BLOCK",
    "MAX_ROWS",
    "PERMUTED_COMBINATIONS",
    "PlanItem",
    "RESTITUTION_SCALE",
    "RepeatedRowsWarning",
    "canonical",
    "compared_form",
    "differences",
    "from_dict",
    "load",
    "parse_rows",
    "plan",
    "row_labels",
    "scene_data",
]

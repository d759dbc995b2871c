"""Bank specs: a TOML file describing many variations of one preset, and their plan
(docs/banks.md, "Every key of a spec"). Each row draws from its own generator
``default_rng([seed, i])``, so raising ``count`` only adds rows; a spec that cannot be run is
a :class:`BankSpecError` naming the key, its value and what is allowed, before any work."""

from synth.lazy import lazy_names

#: Where each public name lives, imported on first use (PEP 562).
_LAZY = {
    name: module
    for module, names in {
        "loading": "from_dict load",
        "model": "BANK_MAX_IMPACTS ENGINE FORMATS MAX_ROWS RESTITUTION_SCALE BankSpec "
        "BankSpecError canonical compared_form",
        "naming": "row_labels",
        "planning": "PlanItem differences parse_rows plan scene_data",
        "sampling": "LHS_BLOCK PERMUTED_COMBINATIONS RepeatedRowsWarning",
    }.items()
    for name in names.split()
}

__all__ = sorted(_LAZY)


__getattr__, __dir__ = lazy_names(__name__, _LAZY)

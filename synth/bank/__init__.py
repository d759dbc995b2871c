"""Sound banks: many physical variations of one preset, rendered by long-lived workers
(a process pool, or a Dask cluster), each file written atomically and recorded in a
manifest; a rerun resumes (docs/banks.md; ``synth bank SPEC -o DIR``).
"""

from synth.lazy import lazy_names

#: Where each public name lives, imported on first use (PEP 562): the command line reads the
#: options' declaration (:mod:`synth.bank.options`) without loading the banks.
_LAZY = dict.fromkeys(("BankResult", "BankRunError", "run"), "runner") | dict.fromkeys(
    ("BankSpec", "BankSpecError", "PlanItem", "load", "plan"), "spec"
)

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_names(__name__, _LAZY)

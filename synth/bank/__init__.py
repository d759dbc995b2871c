"""Sound banks: many physical variations of one preset, rendered by long-lived workers
(a process pool, or a Dask cluster), each file written atomically and recorded in a
manifest; a rerun resumes.

* :mod:`synth.bank.spec`: the TOML spec, checked, and its plan;
* :mod:`synth.bank.run`: the run (:func:`run`): lock, resume, manifest, the final check;
* :mod:`synth.bank.row`: one row rendered, encoded and measured;
* :mod:`synth.bank.executors`: where rows render: this process, a pool, a Dask cluster;
* :mod:`synth.bank.manifest`: ``manifest.jsonl`` / ``manifest.csv`` and the stored spec.

``synth bank SPEC -o DIR`` on the command line.
"""

from synth.bank.run import BankResult, BankRunError, run
from synth.bank.spec import BankSpec, BankSpecError, PlanItem, load, plan

__all__ = [
    "BankResult",
    "BankRunError",
    "BankSpec",
    "BankSpecError",
    "PlanItem",
    "load",
    "plan",
    "run",
]

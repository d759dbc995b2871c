"""Sound banks: many physical variations of one preset, rendered by long-lived workers
(a process pool, or a Dask cluster), each file written atomically and recorded in a
manifest; a rerun resumes.

* :mod:`synth.bank.spec`: the TOML spec, checked, and its plan;
* :mod:`synth.bank.options`: the run's options, declared once (also the CLI's flags);
* :mod:`synth.bank.run`: the run (:func:`run`): lock, resume, manifest, the final check;
* :mod:`synth.bank.row`: one row rendered, encoded and measured;
* :mod:`synth.bank.executors`: where rows render: this process, a pool, a Dask cluster;
* :mod:`synth.bank.manifest`: ``manifest.jsonl`` / ``manifest.csv`` and the stored spec.

``synth bank SPEC -o DIR`` on the command line.
"""

from synth.lazy import lazy_names

#: Where each public name lives, imported on first use (PEP 562): the command line reads the
#: options' declaration (:mod:`synth.bank.options`) without loading the banks.
_LAZY = {
    "BankResult": "run",
    "BankRunError": "run",
    "run": "run",
    "BankSpec": "spec",
    "BankSpecError": "spec",
    "PlanItem": "spec",
    "load": "spec",
    "plan": "spec",
}

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_names(__name__, _LAZY)

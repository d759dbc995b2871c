"""The options of :func:`synth.bank.run`, declared once: its docstring and the flags of
``synth bank`` are made from this table. Plain data, so the command line reads it without
loading the banks."""

#: name: (argparse keywords, what it does).
OPTIONS = {
    "jobs": (
        {"type": int, "metavar": "N"},
        "worker processes (default: the cores; 1 renders here)",
    ),
    "scheduler": (
        {"metavar": "ADDRESS"},
        "run on a Dask cluster (a scheduler's address tcp://host:8786, or a client) instead "
        "of local workers",
    ),
    "dry_run": (
        {"action": "store_true"},
        "change nothing: list the rows to render (JSON lines) and estimate the time from a "
        "few rows run in a scratch folder",
    ),
    "force": (
        {"action": "store_true"},
        "start over in a folder made by another spec (deletes its files)",
    ),
    "redo": ({"metavar": "ROWS"}, "render these rows again although complete (e.g. 17,40-45)"),
    "prune": (
        {"action": "store_true"},
        "delete the audio files in the folder that are in neither the manifest nor the plan "
        "(without it they are only reported)",
    ),
}

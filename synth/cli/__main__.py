"""``python -m synth.cli``: the command-line interface."""

from synth.cli import main

raise SystemExit(main())

"""``python -m synth``: the command-line interface."""

from synth.cli import main

raise SystemExit(main())

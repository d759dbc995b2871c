"""``python -m synth``: the command-line interface."""

from .cli import main

raise SystemExit(main())

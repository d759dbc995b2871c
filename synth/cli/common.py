"""What several subcommands share: a preset and its overrides, JSON output."""

from __future__ import annotations

import json
import sys


def print_json(obj) -> int:
    """``obj`` as indented JSON on stdout (other numbers as floats); exit status 0."""
    json.dump(obj, sys.stdout, indent=1, default=float)
    print()
    return 0


def add_preset_args(p):
    """Add a preset (a file or an installed name) and its ``--set KEY=VALUE`` overrides."""
    p.add_argument("preset", help="preset file (NAME.toml) or preset name")
    p.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a preset key, e.g. --set ball.radius=0.007 (repeatable)",
    )

"""The arguments several subcommands share: a preset and its overrides."""

from __future__ import annotations


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

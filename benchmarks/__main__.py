"""``python -m benchmarks NAME [options]``: the same as ``synth bench NAME [options]`` (run
from the repository's root, so that this package is found)."""

import sys

from benchmarks.cli import main
from synth.errors import SynthError

PROG = "python -m benchmarks"

try:
    status = main(sys.argv[1:], prog=PROG)
except SynthError as exc:
    print(f"{PROG}: error: {exc}", file=sys.stderr)
    status = 2
raise SystemExit(status)

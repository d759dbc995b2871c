"""Old name of :mod:`synth.store.reproducible`, kept for existing imports: the same module."""

import sys

from synth.store import reproducible

sys.modules[__name__] = reproducible

"""Old name of :mod:`synth.store.atomic`, kept for existing imports: the same module."""

import sys

from synth.store import atomic

sys.modules[__name__] = atomic

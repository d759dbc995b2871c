"""Old name of :mod:`synth.store.cache`, kept for existing imports: the same module."""

import sys

from synth.store import cache

sys.modules[__name__] = cache

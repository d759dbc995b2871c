"""The live engine: an always open output stream on which UI and game code trigger
physical impacts (see :mod:`synth.live.engine`)."""

from synth.live.engine import Body, Engine, EngineStats, Voice, ears

__all__ = ["Body", "Engine", "EngineStats", "Voice", "ears"]

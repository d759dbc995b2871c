"""Perception stimuli: bounce sequences and recordings altered on purpose (restitution scaled,
timing of one scene with the ticks of another). See docs/analysis.md."""

from synth.stimuli.sequences import mismatch_sequence, scaled_sequence

__all__ = ["mismatch_sequence", "scaled_sequence"]

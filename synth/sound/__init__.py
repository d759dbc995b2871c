"""From impacts to audio: the plate's modes, the microphone's radiation gains, the modal bank
that mixes every force pulse into the modes' ringing, and the renderer that ties them to a
scene. See docs/physics.md."""

"""Everything that touches files or devices: audio files, presets, plots, playback and the
on-disk cache."""

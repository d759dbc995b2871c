"""The front ends that touch files or devices: presets, plots and playback (the disk
itself is :mod:`synth.store`)."""

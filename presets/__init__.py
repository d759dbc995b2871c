"""The engine's presets (TOML files), installed with the package as ``synth._presets``."""

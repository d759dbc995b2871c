"""The engine's exception tree.

``SynthError`` is the root. ``ParameterError`` is raised for bad input (a field
with a value outside what the physics allows); it is also a ``ValueError`` so
that generic callers can catch it as one. Numerical trouble inside a solver is
never raised: it is reported in the solver's result (``success``, ``status``,
``message``), in the manner of scipy's ``solve_ivp``.
"""


class SynthError(Exception):
    """Root of every error the engine raises on purpose."""


class ParameterError(SynthError, ValueError):
    """Bad input: the message names the field, its value and what is allowed."""

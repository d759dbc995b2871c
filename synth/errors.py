"""The engine's exception tree.

``ParameterError`` (bad input) is also a ``ValueError``. Numerical trouble inside a solver
is never raised: it is reported in the solver's result (``success``, ``status``,
``message``), as scipy's ``solve_ivp`` does.
"""


class SynthError(Exception):
    """Root of every error the engine raises on purpose."""


class ParameterError(SynthError, ValueError):
    """Bad input: the message names the field, its value and what is allowed."""

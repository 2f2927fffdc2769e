"""The project's user errors.

A :class:`ParameterError` is a value a user gave that cannot be right (missing,
non-finite, negative, out of range, physically impossible); a :class:`ConfigError` is a
configuration file or ``--set`` value that does not fit the schema.  Every command line
prints one of them as one line and exits with code 2; a running node logs it and keeps
its last valid state.  Every layer raises them (the physics included): this module
imports nothing.
"""

__all__ = ['ParameterError', 'ConfigError']


class ParameterError(ValueError):
    """A drilling parameter is missing, non-finite or physically impossible."""


class ConfigError(ParameterError):
    """A configuration that does not fit the schema (one line: where, key, value, rule)."""

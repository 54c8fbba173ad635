"""Exceptions and warnings of pneumo.

Every error of the simulator reaches Python as one of these classes, with the
same one-line message the ``pneumo`` command prints after ``error:``.
"""

from __future__ import annotations

__all__ = [
    "PneumoError",
    "NetlistError",
    "SimulationError",
    "UsageError",
    "DataError",
    "FileError",
    "PneumoWarning",
    "IncompleteRunWarning",
]


class PneumoError(Exception):
    """Base class of every pneumo error."""


class NetlistError(PneumoError):
    """The netlist is wrong: JSON syntax, units, wiring, parameters, overrides
    (``--set``), subsystem files."""


class SimulationError(PneumoError):
    """The solver could not run the model (settings, integration failure,
    chattering events, a rest state it cannot find)."""


class UsageError(PneumoError, ValueError):
    """An argument is wrong (a ``vary`` target or value, a shard, a limit)."""


class DataError(PneumoError, ValueError):
    """Measured data or an experiments manifest is wrong, or an analysis
    cannot proceed with it."""


class FileError(PneumoError, OSError):
    """A file could not be read or written."""


class PneumoWarning(UserWarning):
    """A value was accepted but is probably not what was meant (a plain
    number where a unit was expected, say)."""


class IncompleteRunWarning(PneumoWarning):
    """A run reached its end time before completing the cycles asked for; its
    results are valid up to there (``Result.incomplete`` says where the
    actuator stalled)."""

"""pneumo — simulation of pneumatic systems from JSON netlists.

Chambers with an energy balance, ISO 6358 valves, pistons with
pressure-dependent friction and stick–slip, after *"Improving gas dynamic
models for pneumatic systems"*. The same engine as the ``pneumo`` command:

>>> import pneumo
>>> m = pneumo.load("models/meter_out.json")
>>> m.set(**{"supply.p": "6 bar"})
>>> r = m.simulate(cycles=3)
>>> r.summary["cycles"][0]["total_s"], r["head.p"].max()
>>> df = pneumo.sweep(m, vary={"flow_control.C": ["2.68 L/min/bar", "13.2 L/min/bar"]})

Values are SI floats or strings with units (``"6 bar"``). See
docs/python.md for the guide and :func:`sweep` for Dask clusters.
"""

from ._errors import (
    DataError,
    FileError,
    IncompleteRunWarning,
    NetlistError,
    PneumoError,
    PneumoWarning,
    SimulationError,
    UsageError,
)
from ._discrepancy import DiscrepancyResult, discrepancy
from ._fmu import export_fmu
from ._linearize import Linearization
from ._misc import blocks, schema
from ._model import Model, Result, load, loads
from ._pneumo import __version__
from ._sweep import read_sweep, sweep

__all__ = [
    "__version__",
    "load",
    "loads",
    "Model",
    "Result",
    "sweep",
    "read_sweep",
    "discrepancy",
    "DiscrepancyResult",
    "Linearization",
    "export_fmu",
    "blocks",
    "schema",
    "main",
    "PneumoError",
    "NetlistError",
    "SimulationError",
    "UsageError",
    "DataError",
    "FileError",
    "PneumoWarning",
    "IncompleteRunWarning",
]


def main(argv=None) -> int:
    """Run the ``pneumo`` command line in this process (``python -m pneumo``);
    ``argv`` without the program name (default: ``sys.argv[1:]``)."""
    import sys

    from . import _pneumo

    args = sys.argv[1:] if argv is None else list(argv)
    return int(_pneumo.main(["pneumo", *map(str, args)]))

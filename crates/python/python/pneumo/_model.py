"""Models and results: :func:`load`, :class:`Model`, :class:`Result`."""

from __future__ import annotations

import json
import os
import warnings
from typing import TYPE_CHECKING, Any, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _pneumo
from ._errors import IncompleteRunWarning, PneumoWarning
from ._values import assignments, merge_values

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

    from ._linearize import Linearization

__all__ = ["Model", "Result", "load", "loads"]

PathLike = Union[str, "os.PathLike[str]"]


#: Signals listed in full by an "unknown signal" message; a larger circuit
#: lists this many and the count (as the command line does).
SIGNALS_LISTED = 24


def _unknown_signal(name: object, columns: Sequence[str]) -> str:
    """One short line: the name's repr shortened, the first signals, the count."""
    shown = repr(name)
    if len(shown) > 200:
        shown = f"{shown[:20]}… ({len(shown)} characters)"
    listed = ", ".join(columns[:SIGNALS_LISTED])
    more = f", … and {len(columns) - SIGNALS_LISTED} more ({len(columns)} in all)" if len(columns) > SIGNALS_LISTED else ""
    return f"unknown signal {shown} (available: {listed}{more})"


def load(path: PathLike) -> "Model":
    """Read a netlist file (and the subsystem files it names).

    >>> m = pneumo.load("models/meter_out.json")

    Raises :class:`pneumo.NetlistError` (a wrong netlist or a missing file)
    with the message ``pneumo check`` prints.
    """
    return Model(_pneumo.Netlist.load(os.fspath(path)))


def loads(text: str, name: PathLike = "<string>.json") -> "Model":
    """A netlist given as JSON text. ``name`` is how messages and results
    name it; subsystem files are read relative to its folder."""
    return Model(_pneumo.Netlist.from_text(text, os.fspath(name)))


def _restore(path: str, files: List[Tuple[str, str]], sets: List[str], si_numbers: Sequence[str] = ()) -> "Model":
    return Model(_pneumo.Netlist.from_state(path, files, sets, list(si_numbers)))


class Model:
    """A circuit read from a netlist, with parameter overrides.

    A model holds the text of its files, so it can be pickled and sent to
    another process (a Dask worker) without the files. Values are SI numbers
    or strings with units (``"6 bar"``, ``"13.2 L/min/bar"``), exactly as
    after ``--set`` on the command line.
    """

    def __init__(self, netlist: "_pneumo.Netlist") -> None:
        self._netlist = netlist

    # -- identity ---------------------------------------------------------

    @property
    def name(self) -> str:
        """The netlist's name."""
        return self._netlist.name

    @property
    def path(self) -> str:
        """The path the model was loaded from, as given."""
        return os.fspath(self._netlist.path)

    @property
    def sets(self) -> List[str]:
        """The overrides applied, as ``"ID.PARAM=VALUE"`` texts in order."""
        return list(self._netlist.sets)

    @property
    def sha256(self) -> str:
        """SHA-256 of the bytes of every netlist file read (for a netlist
        without subsystems, what ``sha256sum`` prints)."""
        return self._netlist.sha256

    @property
    def files(self) -> List[str]:
        """Every file read for the model (the netlist, then its subsystems)."""
        return [os.fspath(p) for p in self._netlist.files]

    # -- parameters -------------------------------------------------------

    def set(self, values: Optional[Mapping[str, Any]] = None, /, **kwargs: Any) -> "Model":
        """Override parameters in place and return the model.

        ``m.set(**{"supply.p": "6 bar"})`` or ``m.set({"supply.p": 6e5})``.
        Names are those of ``pneumo --set``: ``ID.PARAM``, a named parameter
        (``bore``), ``gas.model``, ``simulation.rtol``; a value may be an
        expression (``"= supply.p - 0.2 bar"``). Expressions depending on a
        changed value follow it. Raises :class:`pneumo.NetlistError` for an
        unknown name or a wrong unit; the model is then unchanged.
        """
        self._netlist = self._netlist.with_sets(*assignments(merge_values(values, kwargs)))
        return self

    def with_params(self, values: Optional[Mapping[str, Any]] = None, /, **kwargs: Any) -> "Model":
        """A copy of the model with these overrides (the model itself is unchanged)."""
        return Model(self._netlist.with_sets(*assignments(merge_values(values, kwargs))))

    def copy(self) -> "Model":
        """An independent copy."""
        return Model(self._netlist.with_sets([]))

    @property
    def parameters(self) -> Dict[str, Any]:
        """Every parameter after the overrides, in SI: named parameters,
        block parameters and initial values (written, derived or default),
        choices as words, the gas. Initial values left to the rest state show
        their defaults here; the values a run started from are in
        ``Result.summary["initial_rest_state"]``."""
        return {name: value for name, value, _, _ in self._netlist.parameters()}

    def parameter_table(self) -> "pd.DataFrame":
        """:attr:`parameters` as a DataFrame indexed by name, with the SI
        unit and how each value came about (parameter, written, derived,
        default, choice)."""
        import pandas as pd

        rows = self._netlist.parameters()
        df = pd.DataFrame(rows, columns=["name", "value", "unit", "how"]).set_index("name")
        return df

    @property
    def signals(self) -> Dict[str, str]:
        """The signals a run records, with their SI units."""
        return dict(self._netlist.signals())

    # -- checking and saving ----------------------------------------------

    def check(self) -> str:
        """Build the circuit and its rest state; return the report ``pneumo
        check`` prints (causality, parameters, rest state). Warnings are
        issued as :class:`pneumo.PneumoWarning`."""
        text, found = self._netlist.check()
        for w in found:
            warnings.warn(w, PneumoWarning, stacklevel=2)
        return text

    def to_dot(self) -> str:
        """The circuit as Graphviz text."""
        return self._netlist.dot()

    def to_json(self) -> str:
        """The netlist with the overrides written in, as one JSON file
        (subsystems expanded), runnable with ``pneumo simulate``."""
        return self._netlist.to_json()

    def save(self, path: PathLike) -> None:
        """Write :meth:`to_json` to ``path``."""
        with open(path, "w", encoding="utf-8") as f:
            f.write(self.to_json())

    # -- running ----------------------------------------------------------

    def simulate(
        self, cycles: Optional[int] = None, t_end: Optional[float] = None, sensitivities: Optional[Sequence[str]] = None
    ) -> "Result":
        """Run the model, as ``pneumo simulate``.

        ``cycles``: stop after this many actuator cycles (the end time then
        defaults to 60 s per cycle); ``t_end``: end time [s]. Without either,
        the netlist's ``simulation`` settings apply.

        ``sensitivities``: component parameters (``["friction.k0",
        "flow_control.C"]``, numeric and non-zero) whose forward
        sensitivities are integrated beside the run, through its events
        (stick–slip, end stops, valve switching); read them with
        :meth:`Result.sensitivity`. Each costs about one more model
        evaluation per integrator stage. A parameter that changes a discrete
        decision of the run (a mode it would not otherwise take) raises
        :class:`pneumo.SimulationError`.

        The simulation runs without the GIL; Ctrl-C stops it and raises
        ``KeyboardInterrupt``. A run that reaches its end time before
        completing its cycles is returned with :attr:`Result.incomplete` set
        and an :class:`pneumo.IncompleteRunWarning`. Errors raise
        :class:`pneumo.SimulationError` or :class:`pneumo.NetlistError`.
        """
        if cycles is not None:
            if isinstance(cycles, bool) or int(cycles) != cycles or cycles < 0:
                raise ValueError(f"cycles must be a whole number >= 0, got {cycles!r}")
            cycles = int(cycles)
        if t_end is not None:
            t_end = float(t_end)
        if isinstance(sensitivities, str):
            raise TypeError("sensitivities must be a list of parameter names, not one string")
        params = None if sensitivities is None else [str(p) for p in sensitivities]
        raw = self._netlist.simulate(cycles, t_end, params)
        for w in raw.warnings:
            warnings.warn(w, PneumoWarning, stacklevel=2)
        if raw.incomplete is not None:
            warnings.warn(raw.incomplete, IncompleteRunWarning, stacklevel=2)
        return Result(raw)

    def linearize(self, at: Any = "rest", keep_all_states: bool = False) -> "Linearization":
        """The linear model about an operating point, as ``pneumo linearize``.

        ``at``: ``"rest"`` (the netlist's start state), a time of a run of
        the netlist (``"t=1.2 s"``, or a number of seconds), or a trim, the
        equilibrium that meets stated conditions (``"piston.x=200 mm; F=0
        N; head.p=4 bar"``, docs/linearize.md). Inputs and
        outputs are the netlist's ``interface`` section. Returns a
        :class:`pneumo.Linearization` (numpy A, B, C, D with named states,
        inputs and outputs in SI; eigenvalues, natural frequencies, damping
        ratios; ``.to_control()``). ``keep_all_states`` keeps the states no
        output sees. A wrong ``at`` raises :class:`pneumo.UsageError` (a
        ``ValueError``), ``TypeError`` for a value of the wrong type; a
        netlist without an interface :class:`pneumo.NetlistError`.
        """
        from ._linearize import Linearization, operating_point_text

        return Linearization(self._netlist.linearize(operating_point_text(at), bool(keep_all_states)))

    # -- Python protocol --------------------------------------------------

    def __reduce__(self):
        path, files, sets, si_numbers = self._netlist.state()
        return (_restore, (os.fspath(path), [(os.fspath(p), t) for p, t in files], list(sets), list(si_numbers)))

    def __repr__(self) -> str:
        sets = f", sets={self.sets!r}" if self.sets else ""
        return f"<pneumo.Model {self.name!r} from {self.path!r}{sets}>"


class Result:
    """One run: time traces as numpy arrays, the summary as a dict.

    ``r.t`` is the time [s]; ``r["head.p"]`` a signal in SI (NaN where it is
    undefined, as the empty cells of ``pneumo simulate --out``). Arrays are
    read-only views of the result; copy them to change them.
    """

    def __init__(self, raw: "_pneumo.RawResult") -> None:
        self._raw = raw
        self._columns: List[str] = list(raw.columns)
        self._units: Dict[str, str] = dict(zip(self._columns, raw.units))
        self._data: Optional[np.ndarray] = None
        self._summary: Optional[dict] = None

    def _array(self) -> np.ndarray:
        if self._data is None:
            flat = np.frombuffer(self._raw.data(), dtype="<f8")
            self._data = flat.reshape(self._raw.n_rows, len(self._columns) + 1)
        return self._data

    @property
    def t(self) -> np.ndarray:
        """Sample times [s]."""
        return self._array()[:, 0]

    @property
    def columns(self) -> List[str]:
        """Signal names, in the order of the CSV columns."""
        return list(self._columns)

    @property
    def units(self) -> Dict[str, str]:
        """SI unit of each signal (``"Pa"``, ``"K"``, ``"m"``; ``""`` if dimensionless)."""
        return dict(self._units)

    def keys(self) -> List[str]:
        return self.columns

    def __getitem__(self, name: str) -> np.ndarray:
        if name == "t":
            return self.t
        try:
            k = self._columns.index(name)
        except ValueError:
            raise KeyError(_unknown_signal(name, self._columns)) from None
        return self._array()[:, k + 1]

    def __contains__(self, name: object) -> bool:
        return name == "t" or name in self._columns

    def __iter__(self) -> Iterator[str]:
        return iter(self._columns)

    def __len__(self) -> int:
        """Number of samples."""
        return int(self._raw.n_rows)

    @property
    def summary(self) -> Dict[str, Any]:
        """The summary ``pneumo simulate --summary`` writes: ``cycles``
        (start, extend, retract, total [s]), signal ranges, mass and energy
        balances (``conservation``), the rest state, the final state, the mean
        polytropic index and solver statistics."""
        if self._summary is None:
            self._summary = json.loads(self._raw.summary_json())
        return self._summary

    @property
    def cycles(self) -> "pd.DataFrame":
        """The completed cycles as a DataFrame (index: cycle number from 1;
        columns ``start_s``, ``extend_s``, ``retract_s``, ``total_s``)."""
        import pandas as pd

        rows = self.summary["cycles"]
        df = pd.DataFrame(rows, columns=["start_s", "extend_s", "retract_s", "total_s"])
        df.index = pd.RangeIndex(1, len(df) + 1, name="cycle")
        return df

    def sensitivity(self, signal: str, param: str) -> np.ndarray:
        """∂(signal)/∂(param) at the sample times :attr:`t`, for a parameter
        given to ``simulate(..., sensitivities=[...])``: in the signal's SI
        unit per SI unit of the parameter (Pa per N for ``head.p`` and
        ``friction.k0``; m per m³/(s·Pa) for ``piston.x`` and a sonic
        conductance C), NaN where the signal is undefined. Integrated by the
        staggered direct method with the jump conditions at events; agrees
        with central differences of whole runs to about 1e-3 of its largest
        value or better (docs/performance.md, "Parameter sensitivities").
        """
        data = self._raw.sensitivity_data(signal, param)
        if data is None:
            if param not in self._raw.sensitivity_params:
                asked = ", ".join(self._raw.sensitivity_params) or "none"
                raise KeyError(f"no sensitivities to {param!r} (asked for: {asked})")
            raise KeyError(_unknown_signal(signal, self._columns))
        return np.frombuffer(data, dtype="<f8")

    @property
    def incomplete(self) -> Optional[str]:
        """Why the run did less than asked (cycles not completed by the end
        time, and where the actuator stalled), or None."""
        return self._raw.incomplete

    @property
    def t_final(self) -> float:
        """Time the run ended [s]."""
        return self._raw.t_final

    @property
    def events(self) -> List[Tuple[float, str]]:
        """Every discrete event: ``(t, what)``."""
        return list(self._raw.events())

    def to_numpy(self) -> np.ndarray:
        """A copy of all samples: column 0 the time, then :attr:`columns`."""
        return self._array().copy()

    def to_pandas(self, time_index: bool = True) -> "pd.DataFrame":
        """The traces as a DataFrame (a copy).

        With ``time_index=True`` (default) the time is the index, named
        ``"t"``; otherwise it is the first column ``"t"``, as in the CSV.
        Units are in ``df.attrs["units"]``.
        """
        import pandas as pd

        data = self._array()
        df = pd.DataFrame(data[:, 1:].copy(), columns=self._columns)
        if time_index:
            df.index = pd.Index(data[:, 0].copy(), name="t")
        else:
            df.insert(0, "t", data[:, 0].copy())
        df.attrs["units"] = {"t": "s", **self._units}
        df.attrs["model"] = self._raw.model_name
        return df

    def to_csv(self, path: Optional[PathLike] = None, signals: Optional[Sequence[str]] = None, header_units: bool = False) -> Optional[str]:
        """The CSV ``pneumo simulate --out`` writes (all signals, or these):
        written to ``path``, or returned as text without one."""
        text = self._raw.csv(None if signals is None else list(signals), header_units)
        if path is None:
            return text
        with open(path, "w", encoding="utf-8", newline="") as f:
            f.write(text)
        return None

    def plot(self, signals: Optional[Sequence[str]] = None, ax: Any = None, **kwargs: Any) -> Any:
        """Plot signals against time with matplotlib (needs ``matplotlib``).

        Without ``ax``: one panel per quantity (pressures in bar, positions in
        mm, temperatures in K, ...), sharing the time axis; returns the
        Figure. With ``ax``: every signal on that Axes in SI; returns it.
        ``kwargs`` go to ``Axes.plot``.
        """
        from ._plot import plot_result

        return plot_result(self, signals, ax, **kwargs)

    def __repr__(self) -> str:
        n = len(self.summary.get("cycles", []))
        extra = ", incomplete" if self.incomplete else ""
        return f"<pneumo.Result {self._raw.model_name!r}: {len(self)} samples to t = {self.t_final:.4g} s, {n} cycles{extra}>"

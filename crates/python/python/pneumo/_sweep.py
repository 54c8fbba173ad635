"""Parameter sweeps: :func:`sweep` (local threads or a Dask cluster) and
:func:`read_sweep`.

A sweep is the command line's: the same case numbering, the same cases, the
same table. :func:`sweep` returns it as a DataFrame; ``out=`` writes the
exact bytes ``pneumo sweep --out`` writes (CSV or JSON), or Parquet.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
import threading
from typing import TYPE_CHECKING, Any, Dict, Iterable, List, Mapping, Optional, Tuple, Union

import numpy as np

from . import _pneumo
from ._errors import UsageError
from ._values import value_text

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

    from ._model import Model

__all__ = ["sweep", "read_sweep", "read_csv_exact"]

PathLike = Union[str, "os.PathLike[str]"]

PARAM_PREFIX = "param:"
_TEXT_COLUMNS = ("error", "model", "model_sha256", "set", "pneumo_version")


def _as_model(model: Any) -> "Model":
    from ._model import Model, load

    if isinstance(model, Model):
        return model
    if isinstance(model, (str, os.PathLike)):
        return load(model)
    raise TypeError(f"expected a pneumo.Model or a netlist path, got {type(model).__name__}")


def _axes(vary: Mapping[str, Any]) -> List[Tuple[str, List[str]]]:
    if not isinstance(vary, Mapping) or not vary:
        raise UsageError("vary: give a mapping of ID.PARAM to a list of values, e.g. {'supply.p': ['4 bar', '7 bar']}")
    axes = []
    for target, values in vary.items():
        if isinstance(values, (str, bytes, Mapping)) or not isinstance(values, Iterable):
            values = [values]
        texts = [value_text(v, target) for v in values]
        for t in texts:
            if "," in t:
                raise UsageError(f"--vary {target}: the value {t!r} holds a comma (give each value as its own list item)")
        axes.append((str(target), texts))
    return axes


def _shard(shard: Any) -> Optional[Tuple[int, int]]:
    if shard is None:
        return None
    if isinstance(shard, str):
        k, sep, n = shard.partition("/")
        try:
            if not sep:
                raise ValueError
            return int(k), int(n)
        except ValueError:
            raise UsageError(f'--shard "{shard}": expected K/N with 1 <= K <= N (e.g. 3/16)') from None
    k, n = shard
    return int(k), int(n)


def sweep(
    model: Union["Model", PathLike],
    vary: Mapping[str, Any],
    *,
    cycles: Optional[int] = None,
    t_end: Optional[float] = None,
    jobs: Optional[int] = None,
    client: Any = None,
    shard: Union[str, Tuple[int, int], None] = None,
    max_cases: Optional[int] = None,
    out: Optional[PathLike] = None,
) -> "pd.DataFrame":
    """Run a full-factorial parameter study; one DataFrame row per case.

    ``vary`` maps ``ID.PARAM`` to its values (SI numbers or strings with
    units); the first entry changes slowest, as the first ``--vary`` of
    ``pneumo sweep``. The model's overrides (:meth:`Model.set`) are the fixed
    ``--set`` of every case. ``cycles``/``t_end`` as in :meth:`Model.simulate`.

    Where the cases run:

    - locally on ``jobs`` threads (default: all available cores), without
      the GIL; Ctrl-C stops the sweep and raises ``KeyboardInterrupt``;
    - with ``client=`` a ``dask.distributed.Client``: one task per case on
      its workers (which import pneumo themselves; the model travels with the
      task, so workers need no access to the netlist files).

    Either way the table is the one ``pneumo sweep --out`` writes, with the
    same values: columns ``case``, ``n_cases``, one per varied parameter (in
    SI), ``cycleK_extend_s``/``_retract_s``/``_total_s``, ``cycle_time_s``,
    ``<id>.T_min_K``/``_max_K``, ``error`` (NaN on success), then the
    provenance: ``model``, ``model_sha256``, ``set``, ``pneumo_version`` and
    ``param:<name>`` for every parameter each case ran with (see
    docs/sweeps.md). ``df.attrs["pneumo"]`` repeats the study's settings and
    ``df.attrs["units"]`` gives each column's SI unit. A case that fails is
    a row with its one-line error, not an exception.

    ``shard="K/N"`` runs only the cases with index mod N = K - 1 (as
    ``--shard``). ``out=`` also writes the table: ``.csv`` and ``.json``
    byte for byte as ``pneumo sweep --out``, ``.parquet`` with pyarrow (the
    attrs in the file's metadata).
    """
    m = _as_model(model)
    axes = _axes(vary)
    if cycles is not None:
        if isinstance(cycles, bool) or int(cycles) != cycles or cycles < 0:
            raise ValueError(f"cycles must be a whole number >= 0, got {cycles!r}")
        cycles = int(cycles)
    if t_end is not None:
        t_end = float(t_end)
    if jobs is not None:
        if client is not None:
            raise UsageError("jobs applies to local sweeps; with client= the Dask cluster sets the parallelism")
        if isinstance(jobs, bool) or int(jobs) != jobs or jobs < 1:
            raise UsageError("--jobs must be at least 1")
        jobs = int(jobs)
    limit = _pneumo.DEFAULT_MAX_CASES if max_cases is None else int(max_cases)
    plan = _pneumo.SweepPlan(m._netlist, axes, cycles, t_end, _shard(shard), limit)
    indices = plan.selected()
    if client is None:
        outcomes = plan.run(indices, jobs)
    else:
        outcomes = _run_on_dask(client, m, axes, cycles, t_end, plan.n_cases, indices)
    df = _frame(plan, outcomes, m, axes, cycles, t_end, _shard(shard))
    if out is not None:
        _write(out, plan, outcomes, df)
    return df


# -- Dask ---------------------------------------------------------------------

_PLANS: Dict[str, "_pneumo.SweepPlan"] = {}
_PLANS_LOCK = threading.Lock()


def _worker_plan(spec_id: str, spec: tuple) -> "_pneumo.SweepPlan":
    """The plan of a sweep on this worker, built once per process."""
    with _PLANS_LOCK:
        plan = _PLANS.get(spec_id)
        if plan is None:
            path, files, sets, axes, cycles, t_end, n_cases = spec
            netlist = _pneumo.Netlist.from_state(path, files, sets)
            plan = _pneumo.SweepPlan(netlist, axes, cycles, t_end, None, max(n_cases, 1))
            if len(_PLANS) >= 8:
                _PLANS.clear()
            _PLANS[spec_id] = plan
        return plan


def _dask_case(index: int, spec_id: str, spec: tuple) -> tuple:
    """One case on a Dask worker: an outcome tuple (floats travel exactly)."""
    return _worker_plan(spec_id, spec).run_case(index)


def _run_on_dask(client: Any, m: "Model", axes: list, cycles: Optional[int], t_end: Optional[float], n_cases: int, indices: List[int]) -> list:
    path, files, sets, _ = m._netlist.state()
    spec = (os.fspath(path), [(os.fspath(p), t) for p, t in files], list(sets), axes, cycles, t_end, n_cases)
    spec_id = hashlib.sha256(json.dumps(spec).encode("utf-8")).hexdigest()
    shared = client.scatter(spec, broadcast=True, hash=False)
    futures = client.map(_dask_case, indices, spec_id=spec_id, spec=shared, key=[f"pneumo-case-{spec_id[:12]}-{i}" for i in indices])
    try:
        return client.gather(futures)
    except BaseException:
        client.cancel(futures)
        raise


# -- the table ----------------------------------------------------------------


def _column(name: str, values: list) -> Any:
    import pandas as pd

    if name in ("case", "n_cases"):
        return np.asarray(values, dtype=np.int64)
    present = [v for v in values if v is not None]
    if not present or (name not in _TEXT_COLUMNS and all(isinstance(v, float) for v in present)):
        return np.asarray([math.nan if v is None else v for v in values], dtype=np.float64)
    return pd.Series([np.nan if v is None else v for v in values])


def _units(plan: "_pneumo.SweepPlan", m: "Model", header: List[str]) -> Dict[str, str]:
    known = {name: unit for name, _, unit, _ in m._netlist.parameters()}
    known.update({"simulation.t_end": "s", "simulation.sample_interval": "s", "simulation.max_step": "s"})
    units: Dict[str, str] = {}
    for h in header:
        if h.endswith("_s"):
            units[h] = "s"
        elif h.endswith("_min_K") or h.endswith("_max_K"):
            units[h] = "K"
        elif h.startswith(PARAM_PREFIX) and h[len(PARAM_PREFIX):] in known:
            units[h] = known[h[len(PARAM_PREFIX):]]
        elif h in known:
            units[h] = known[h]
    return units


def _frame(plan: "_pneumo.SweepPlan", outcomes: list, m: "Model", axes: list, cycles: Any, t_end: Any, shard: Any) -> "pd.DataFrame":
    import pandas as pd

    header, columns = plan.columns(outcomes)
    df = pd.DataFrame({name: _column(name, values) for name, values in zip(header, columns)}, columns=header)
    df.attrs["pneumo"] = {
        "model": m.path,
        "model_sha256": m.sha256,
        "sets": m.sets,
        "vary": {target: texts for target, texts in axes},
        "cycles": cycles,
        "t_end": t_end,
        "shard": list(shard) if shard else None,
        "n_cases": plan.n_cases,
        "pneumo_version": _pneumo.__version__,
    }
    df.attrs["units"] = _units(plan, m, header)
    return df


def _write(out: PathLike, plan: "_pneumo.SweepPlan", outcomes: list, df: "pd.DataFrame") -> None:
    path = os.fspath(out)
    ext = os.path.splitext(path)[1].lower()
    if ext == ".json":
        data = plan.json(outcomes)
    elif ext == ".parquet":
        data = None
    else:
        data = plan.csv(outcomes)
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".pneumo-", suffix=ext, dir=folder)
    try:
        if data is None:
            os.close(fd)
            _write_parquet(df, tmp)
        else:
            with os.fdopen(fd, "wb") as f:
                f.write(bytes(data))
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _write_parquet(df: "pd.DataFrame", path: str) -> None:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("Parquet output needs pyarrow: python3 -m pip install pyarrow") from e
    table = pa.Table.from_pandas(df, preserve_index=False)
    meta = dict(table.schema.metadata or {})
    meta[b"pneumo"] = json.dumps(df.attrs.get("pneumo", {})).encode("utf-8")
    meta[b"pneumo_units"] = json.dumps(df.attrs.get("units", {})).encode("utf-8")
    pq.write_table(table.replace_schema_metadata(meta), path)


def read_csv_exact(path: PathLike) -> "pd.DataFrame":
    """``pandas.read_csv`` with every float read back bit for bit (pandas
    before 3.0 needs ``float_precision="round_trip"`` for that; 3.0 does it
    by default and deprecates the argument)."""
    import pandas as pd

    if int(pd.__version__.split(".")[0]) >= 3:
        return pd.read_csv(path)
    return pd.read_csv(path, float_precision="round_trip")


def read_sweep(path: PathLike) -> "pd.DataFrame":
    """Read a sweep table written by ``pneumo sweep``/``merge`` (CSV or
    JSON) or by :func:`sweep` (also Parquet) into a DataFrame, numbers bit
    for bit; ``df.attrs["pneumo"]`` is rebuilt from the provenance columns
    (or read from the Parquet metadata)."""
    import pandas as pd

    p = os.fspath(path)
    ext = os.path.splitext(p)[1].lower()
    if ext == ".parquet":
        import pyarrow.parquet as pq

        table = pq.read_table(p)
        df = table.to_pandas()
        meta = table.schema.metadata or {}
        if b"pneumo" in meta:
            df.attrs["pneumo"] = json.loads(meta[b"pneumo"])
        if b"pneumo_units" in meta:
            df.attrs["units"] = json.loads(meta[b"pneumo_units"])
        return df
    if ext == ".json":
        with open(p, encoding="utf-8") as f:
            doc = json.load(f)
        header = doc.get("columns") or (list(doc["cases"][0]) if doc.get("cases") else [])
        rows = doc.get("cases", [])
        values = {h: [r.get(h) for r in rows] for h in header}
        for h, v in values.items():
            if h not in _TEXT_COLUMNS:
                values[h] = [float(x) if isinstance(x, str) and x in ("inf", "-inf", "NaN") else x for x in v]
                values[h] = [float(x) if isinstance(x, int) and h not in ("case", "n_cases") else x for x in values[h]]
        df = pd.DataFrame({h: _column(h, v) for h, v in values.items()}, columns=header)
    else:
        df = read_csv_exact(p)
    if len(df) and "model" in df.columns:
        first = df.iloc[0]
        sets = first.get("set")
        df.attrs["pneumo"] = {
            "model": first.get("model"),
            "model_sha256": first.get("model_sha256"),
            "sets": json.loads(sets) if isinstance(sets, str) else [],
            "n_cases": int(first["n_cases"]),
            "pneumo_version": first.get("pneumo_version"),
        }
    return df

"""The discrepancy workflow: :func:`discrepancy` and its result."""

from __future__ import annotations

import json
import math
import os
from typing import TYPE_CHECKING, Any, Dict, List, Optional, Union

from . import _pneumo

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

    from ._model import Model

__all__ = ["discrepancy", "DiscrepancyResult"]

PathLike = Union[str, "os.PathLike[str]"]


# units whose zero is not SI's zero: an interval cannot be scaled into them
_OFFSET_UNITS = ("degC", "degF", "barg", "psig")


def _unit_scale(e: Dict[str, Any]) -> Optional[float]:
    """Factor from SI to the unit ``shown`` is in (L/min/bar, mm, ...), so
    that an interval reads beside its value (SI intervals of a conductance
    print as 0.0 next to a value in L/min/bar); None when it cannot be told."""
    value, shown = e.get("value"), e.get("shown")
    if e.get("unit") in _OFFSET_UNITS or not value or shown is None:
        return None
    scale = shown / value
    return scale if math.isfinite(scale) and scale > 0 else None


def _estimates(params: List[Dict[str, Any]]) -> "pd.DataFrame":
    import pandas as pd

    rows = []
    for e in params:
        ci = e.get("ci95") or (None, None)
        scale = _unit_scale(e)
        in_unit = lambda x: None if x is None or scale is None else x * scale  # noqa: E731
        # the interval as the report shows it (kept inside the bounds), in the value's unit
        ci_unit = e.get("shown_ci95") or (in_unit(ci[0]), in_unit(ci[1]))
        rows.append(
            {
                "name": e["name"],
                "value": e["value"],
                "unit": e["unit"],
                "value_in_unit": e.get("shown"),
                "std_error_in_unit": in_unit(e.get("std_error")),
                "ci95_low_in_unit": ci_unit[0],
                "ci95_high_in_unit": ci_unit[1],
                "std_error": e.get("std_error"),
                "ci95_low": ci[0],
                "ci95_high": ci[1],
                "at_bound": bool(e.get("at_bound")),
            }
        )
    columns = [
        "name",
        "value",
        "unit",
        "value_in_unit",
        "std_error_in_unit",
        "ci95_low_in_unit",
        "ci95_high_in_unit",
        "std_error",
        "ci95_low",
        "ci95_high",
        "at_bound",
    ]
    return pd.DataFrame(rows, columns=columns).set_index("name")


class DiscrepancyResult:
    """What ``pneumo discrepancy`` finds, as Python objects.

    - :attr:`verdict` — one sentence; :attr:`effects` — the effects added
      (empty when nothing is missing); :attr:`ambiguous` — the alternatives
      when two effects explain the data equally well;
    - :attr:`estimates` — the final model's parameter estimates: ``value``,
      ``std_error`` and the 95 % interval ``ci95_low``/``ci95_high`` in SI,
      and ``value_in_unit``, ``ci95_low_in_unit``/``ci95_high_in_unit`` in
      the parameter's ``unit`` (at a bound the interval is one-sided, from
      the bound); :attr:`baseline_estimates` those of the calibrated
      model without any effect;
    - :attr:`candidates` — every effect tried, with ΔIC, held-out error and
      why it was rejected; :attr:`rmse` — normalised RMSE per channel before
      and after (1 = sensor noise);
    - :attr:`model` — the augmented model (a :class:`pneumo.Model`, ready to
      simulate or save), :attr:`models` — every model written, by label;
    - :attr:`summary` — the ``--json`` output as a dict; :attr:`report_files`
      — files written with ``report=``.
    """

    def __init__(self, found: Dict[str, Any], base: "Model") -> None:
        from ._model import Model

        self.summary: Dict[str, Any] = json.loads(found["summary_json"])
        self.text: str = found["text"]
        self.report_files: List[str] = [os.fspath(p) for p in found["written"]]
        folder = os.path.dirname(os.path.abspath(base.path))
        self.models: Dict[str, "Model"] = {
            label: Model(_pneumo.Netlist.from_text(text, os.path.join(folder, file_name), True)) for label, file_name, text in found["models"]
        }

    @property
    def verdict(self) -> str:
        return self.summary["verdict"]

    @property
    def effects(self) -> List[str]:
        """Names of the effects added to the model, in the order added."""
        return [s["effect"] for s in self.summary["selected"]]

    @property
    def ambiguous(self) -> List[str]:
        return list(self.summary.get("ambiguous", []))

    @property
    def model(self) -> Optional["Model"]:
        """The final model: with the effects added, or calibrated if nothing is missing."""
        return next(iter(self.models.values()), None)

    @property
    def estimates(self) -> "pd.DataFrame":
        return _estimates(self.summary["after"]["params"])

    @property
    def baseline_estimates(self) -> "pd.DataFrame":
        return _estimates(self.summary["baseline"]["params"])

    @property
    def effect_parameters(self) -> Dict[str, Dict[str, float]]:
        """``{effect: {parameter: SI value}}`` of the effects added."""
        return {s["effect"]: dict(s["params"]) for s in self.summary["selected"]}

    @property
    def candidates(self) -> "pd.DataFrame":
        import pandas as pd

        rows = [
            {
                "round": c["round"],
                "effect": c["effect"],
                "delta_ic": c["delta_ic"],
                "heldout_rmse": c["heldout_rmse"],
                "gap_explained": c["gap_explained"],
                "accepted": c["accepted"],
                "reasons": "; ".join(c["reasons"]),
                "params": c["params"],
            }
            for c in self.summary["candidates"]
        ]
        return pd.DataFrame(rows, columns=["round", "effect", "delta_ic", "heldout_rmse", "gap_explained", "accepted", "reasons", "params"])

    @property
    def rmse(self) -> "pd.DataFrame":
        """Normalised RMSE per channel (1 = noise level), before and after."""
        import pandas as pd

        return pd.DataFrame({"baseline": self.summary["baseline"]["rmse_normalized"], "after": self.summary["after"]["rmse_normalized"]})

    def __repr__(self) -> str:
        return f"<pneumo.DiscrepancyResult: {self.verdict}>"

    def _repr_markdown_(self) -> str:  # Jupyter
        return f"**{self.verdict}**\n\n```\n{self.text}```"


def discrepancy(model: Union["Model", PathLike], experiments: PathLike, *, report: Optional[PathLike] = None) -> DiscrepancyResult:
    """Compare a model with measurements and name the effect it is missing,
    as ``pneumo discrepancy`` (docs/discrepancy.md).

    ``experiments`` is the manifest (JSON) listing the measured CSV files and
    each run's operating point; the model's overrides apply. With
    ``report=DIR`` the report directory of ``--report`` is written too
    (augmented netlists, figures, report.md, summary.json).

    Runs without the GIL on all cores; Ctrl-C stops it (every simulation of
    the analysis is cancelled) and raises ``KeyboardInterrupt``. Errors in
    the manifest or data raise :class:`pneumo.DataError`.
    """
    from ._sweep import _as_model

    m = _as_model(model)
    found = _pneumo.discrepancy(m._netlist, os.fspath(experiments), None if report is None else os.fspath(report))
    return DiscrepancyResult(found, m)

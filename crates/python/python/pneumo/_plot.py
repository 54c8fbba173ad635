"""Plots of results with matplotlib (an optional dependency)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Dict, List, Optional, Sequence, Tuple

if TYPE_CHECKING:  # pragma: no cover
    from ._model import Result

__all__ = ["plot_result"]

# SI unit -> (quantity, display unit, factor from SI), as `pneumo plot` shows them
_DISPLAY: Dict[str, Tuple[str, str, float]] = {
    "Pa": ("pressure", "bar", 1e-5),
    "m": ("position", "mm", 1e3),
    "m/s": ("velocity", "m/s", 1.0),
    "K": ("temperature", "K", 1.0),
    "kg": ("mass", "g", 1e3),
    "kg/s": ("mass flow", "g/s", 1e3),
    "N": ("force", "N", 1.0),
}


def _pyplot() -> Any:
    try:
        import matplotlib.pyplot as plt
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("Result.plot needs matplotlib: python3 -m pip install matplotlib") from e
    return plt


def plot_result(result: "Result", signals: Optional[Sequence[str]], ax: Any, **kwargs: Any) -> Any:
    names: List[str] = list(signals) if signals is not None else result.columns
    for n in names:
        result[n]  # KeyError naming the available signals
    t = result.t
    units = result.units
    if ax is not None:
        for n in names:
            ax.plot(t, result[n], label=f"{n} [{units[n] or '1'}]", **kwargs)
        ax.set_xlabel("t [s]")
        ax.legend()
        return ax
    plt = _pyplot()
    groups: Dict[str, List[str]] = {}
    for n in names:
        groups.setdefault(units[n], []).append(n)
    fig, axes = plt.subplots(len(groups), 1, sharex=True, squeeze=False, figsize=(8, 2.6 * len(groups) + 0.6))
    for panel, (unit, members) in zip(axes[:, 0], groups.items()):
        quantity, shown, factor = _DISPLAY.get(unit, (unit or "value", unit or "1", 1.0))
        for n in members:
            panel.plot(t, result[n] * factor, label=n, **kwargs)
        panel.set_ylabel(f"{quantity} [{shown}]")
        panel.grid(True, alpha=0.3)
        panel.legend(loc="best", fontsize="small")
    axes[-1, 0].set_xlabel("t [s]")
    fig.suptitle(result._raw.model_name)
    fig.tight_layout()
    return fig

"""Python values as the text of ``ID.PARAM=VALUE`` overrides."""

from __future__ import annotations

import math
import numbers
from typing import Any, Mapping, Optional

__all__ = ["assignment", "assignments", "value_text", "merge_values"]


def value_text(value: Any, name: str) -> str:
    """The netlist text of one value: strings as written (units allowed,
    ``"6 bar"``), numbers in SI (``6e5``), lists for list parameters."""
    if isinstance(value, str):
        text = value.strip()
        if not text:
            raise ValueError(f"{name}: empty value")
        if "\n" in text or "\r" in text:
            raise ValueError(f"{name}: a value is one line of text")
        return text
    if isinstance(value, bool):
        raise TypeError(f"{name}: expected a number or a text with a unit, got {value!r}")
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        x = float(value)
        if math.isnan(x):
            raise ValueError(f"{name}: NaN is not a value")
        return repr(x)
    if isinstance(value, (list, tuple)):
        return ", ".join(value_text(v, name) for v in value)
    raise TypeError(f"{name}: expected a number, a text with a unit or a list, got {type(value).__name__}")


def assignment(name: str, value: Any) -> str:
    """``"ID.PARAM=VALUE"`` for ``pneumo --set``."""
    if not isinstance(name, str) or not name.strip():
        raise TypeError(f"parameter names are strings such as 'supply.p', got {name!r}")
    return f"{name.strip()}={value_text(value, name)}"


def merge_values(values: Optional[Mapping[str, Any]], kwargs: Mapping[str, Any]) -> dict:
    """One mapping from a positional mapping and keyword arguments."""
    merged: dict = {}
    if values is not None:
        if not isinstance(values, Mapping):
            raise TypeError(f"expected a mapping of parameter names to values, got {type(values).__name__}")
        merged.update(values)
    merged.update(kwargs)
    return merged


def assignments(values: Mapping[str, Any]) -> "tuple[list, list]":
    """``(["ID.PARAM=VALUE", ...], [names given as numbers])``."""
    sets = [assignment(k, v) for k, v in values.items()]
    numbers_ = [k.strip() for k, v in values.items() if isinstance(v, numbers.Real) and not isinstance(v, bool)]
    return sets, numbers_

"""Reference information: the block library and the netlist schema."""

from __future__ import annotations

import json
from typing import Any, Dict

from . import _pneumo

__all__ = ["blocks", "schema"]


def blocks() -> str:
    """Every block type with its ports, units and parameters (``pneumo blocks``)."""
    return _pneumo.blocks()


def schema() -> Dict[str, Any]:
    """The JSON Schema of netlists (``pneumo schema``)."""
    return json.loads(_pneumo.schema_json())

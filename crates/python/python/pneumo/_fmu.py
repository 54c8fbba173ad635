"""FMU export: :func:`export_fmu` (issue 26, docs/fmu.md)."""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Optional, Union

from ._errors import UsageError
from ._model import Model, PathLike, load

__all__ = ["export_fmu", "RUNTIME_LIBRARY", "find_runtime"]

#: File name of the FMU runtime library (crates/fmu), built by
#: ``cargo build --release`` next to the ``pneumo`` executable.
RUNTIME_LIBRARY = "libpneumo_fmu.so"


def find_runtime() -> Optional[Path]:
    """The FMU runtime library to put in an FMU, or None: the file named by
    the environment variable ``PNEUMO_FMU_RUNTIME``, else the one next to the
    ``pneumo`` executable on the PATH."""
    named = os.environ.get("PNEUMO_FMU_RUNTIME")
    if named:
        return Path(named)
    exe = shutil.which("pneumo")
    if exe:
        beside = Path(exe).resolve().parent / RUNTIME_LIBRARY
        if beside.is_file():
            return beside
    return None


def export_fmu(model: Union[Model, PathLike], path: PathLike, runtime: Optional[PathLike] = None) -> Path:
    """Export ``model`` (a :class:`Model` or a netlist file) as an FMI 2.0
    Co-Simulation FMU at ``path``, as ``pneumo fmu``; returns the path.

    The FMU carries the netlist files as read and the runtime library
    ``runtime`` (default: :func:`find_runtime`; build it with ``cargo build
    --release -p pneumo-fmu``, it is ``target/release/libpneumo_fmu.so``).
    Interface inputs and outputs become FMU inputs and outputs, top-level
    parameters tunable parameters (docs/fmu.md). A model with overrides is
    refused: the FMU would not carry them. Nothing is written on an error
    (:class:`pneumo.UsageError`, :class:`pneumo.NetlistError`,
    :class:`pneumo.FileError`).
    """
    m = model if isinstance(model, Model) else load(model)
    lib = Path(runtime) if runtime is not None else find_runtime()
    if lib is None:
        raise UsageError(
            "no FMU runtime library: pass runtime=PATH or set PNEUMO_FMU_RUNTIME; build it with "
            "`cargo build --release -p pneumo-fmu` (target/release/libpneumo_fmu.so)"
        )
    m._netlist.export_fmu(os.fspath(path), os.fspath(lib))
    return Path(path)

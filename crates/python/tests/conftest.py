"""Shared fixtures: the repository's models and the ``pneumo`` command line
run as ``python -m pneumo`` (the same library code as the cargo binary)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
METER_OUT = ROOT / "models" / "meter_out.json"


@pytest.fixture
def root() -> Path:
    return ROOT


@pytest.fixture
def meter_out() -> Path:
    return METER_OUT


def run_cli(*args: str, cwd: Path = ROOT, check: bool = True) -> subprocess.CompletedProcess:
    """``pneumo ARGS`` in a child process; fails the test on a non-zero exit if ``check``."""
    out = subprocess.run([sys.executable, "-m", "pneumo", *args], cwd=cwd, capture_output=True, text=True)
    if check and out.returncode != 0:
        raise AssertionError(f"pneumo {' '.join(args)} exited {out.returncode}: {out.stderr}")
    return out


def cli_error(*args: str) -> str:
    """The one-line message of a failing command, without ``error: ``."""
    out = run_cli(*args, check=False)
    assert out.returncode != 0, out.stdout
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), out.stderr
    return lines[0][len("error: ") :]


@pytest.fixture
def cli():
    return run_cli


@pytest.fixture
def cli_message():
    return cli_error


@pytest.fixture
def python_child():
    """Start a child Python running ``code`` from the repository root, its output piped."""
    started = []

    def start(code: str) -> subprocess.Popen:
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        child = subprocess.Popen([sys.executable, "-c", code], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        started.append(child)
        return child

    yield start
    for child in started:
        if child.poll() is None:
            child.kill()
            child.wait()


@pytest.fixture(scope="session")
def fmu_runtime() -> Path:
    """The FMU runtime library of this checkout (crates/fmu), never a stale
    copy: the file ``PNEUMO_FMU_RUNTIME`` names (scripts/test-all builds it
    with ``cargo build --release --locked -p pneumo-fmu`` just before the
    Python tests and names it there), else the one cargo builds now. Skipped
    with the reason when neither is possible (a package installed without
    its source tree)."""
    named = os.environ.get("PNEUMO_FMU_RUNTIME")
    if named:
        path = Path(named)
        assert path.is_file(), f"PNEUMO_FMU_RUNTIME={named} is not a file"
        return path
    import json
    import shutil

    if shutil.which("cargo") is None or not (ROOT / "Cargo.toml").is_file():
        pytest.skip("no FMU runtime library: set PNEUMO_FMU_RUNTIME or run from a checkout with cargo (scripts/test-all does)")
    out = subprocess.run(
        ["cargo", "build", "--release", "--locked", "-p", "pneumo-fmu", "--message-format=json-render-diagnostics"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
    for line in out.stdout.splitlines():
        msg = json.loads(line)
        if msg.get("reason") == "compiler-artifact" and "cdylib" in msg.get("target", {}).get("crate_types", []):
            for f in msg.get("filenames", []):
                if f.endswith(".so"):
                    return Path(f)
    raise AssertionError("cargo built no libpneumo_fmu.so")

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

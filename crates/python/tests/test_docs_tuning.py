"""docs/position_control_tuning.md (issue 25): its Python blocks are run in
order, from the repository's root, and each one's printed output is compared
with the ```text block that follows it on the page — text exactly, numbers
to the digits shown within 0.5 %, as crates/cli/tests/tutorial.rs compares
the command line's output."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

pytest.importorskip("control", reason="python-control is not installed (pip install ./crates/python[test] installs it)")

ROOT = Path(__file__).resolve().parents[3]
PAGE = ROOT / "docs" / "position_control_tuning.md"
NUMBER = re.compile(r"(?<![\w.])-?\d+(?:\.\d+)?(?:e-?\d+)?")


def python_blocks_with_outputs(text: str):
    """(code, expected output) for every ```python block followed by a ```text block."""
    pairs = re.findall(r"```python\n(.*?)```\s*```text\n(.*?)```", text, re.S)
    return [(code, out) for code, out in pairs]


def mismatch(expected: str, actual: str):
    """Why the line `actual` does not read as `expected`, or None."""
    if NUMBER.sub("#", expected) != NUMBER.sub("#", actual):
        return f"text differs: {expected!r} vs {actual!r}"
    for word, got in zip(NUMBER.findall(expected), NUMBER.findall(actual)):
        decimals = len(word.split("e")[0].split(".")[1]) if "." in word.split("e")[0] else 0
        exponent = int(word.split("e")[1]) if "e" in word else 0
        allowed = 0.5 * 10.0 ** (exponent - decimals) + 0.005 * abs(float(word))
        if abs(float(word) - float(got)) > allowed:
            return f"{word} on the page, {got} from the run (allowed ±{allowed:g})"
    return None


def test_the_comparison_reads_numbers_to_the_digits_shown():
    assert mismatch("f_n = 16.188 Hz", "f_n = 16.1884 Hz") is None
    assert mismatch("f_n = 16.188 Hz", "f_n = 17.188 Hz") is not None
    assert mismatch("overshoot 0.0 %", "overshoot 0.04 %") is None
    assert mismatch("settling not settled", "settling 0.3 s") is not None


def test_the_tuning_page_runs_as_written_and_prints_what_it_shows(monkeypatch):
    pairs = python_blocks_with_outputs(PAGE.read_text())
    assert len(pairs) == 3, "the page's three Python blocks, each with its output"
    monkeypatch.chdir(ROOT)
    namespace: dict = {}
    for code, expected in pairs:
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            exec(compile(code, str(PAGE), "exec"), namespace)
        actual = out.getvalue().splitlines()
        assert len(actual) == len(expected.splitlines()), f"the page shows\n{expected}\nthe block printed\n{out.getvalue()}"
        for e, a in zip(expected.splitlines(), actual):
            why = mismatch(e, a)
            assert why is None, f"{PAGE.name} is stale: {why}\n page: {e}\n  run: {a}"

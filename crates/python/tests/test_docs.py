"""docs/python.md and README.md's Python cannot go stale.

docs/python.md: the ```python blocks written as a session (lines starting
with ``>>> ``) run in order in one namespace, in an empty folder that holds
only a link to the repository's ``models/``, each line as the interactive
interpreter runs it (an expression's value is printed); what the page shows
under a line is that line's output. Lines are compared one by one: text
exactly (runs of spaces count as one, so a column that grows a digit still
matches), numbers to the digits shown within 0.5 % (the rule of
crates/cli/tests/tutorial.rs), and a line ending in ``…`` only up to the
``…``. A block whose info string says ``slow`` (```python slow: the
discrepancy analysis, minutes) runs only with ``PNEUMO_SLOW_DOCS=1``; its
numbers are also checked against the committed example report by
``cargo test -p pneumo-cli --test example_report``. Blocks without ``>>>``
are illustrations (a Slurm cluster) and are not run.

README.md: its ```python block runs as a script (a local Dask cluster).
"""

from __future__ import annotations

import contextlib
import doctest
import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]

_NUMBER = re.compile(r"\d[\d.]*(?:e-?\d+)?")


def pieces(line: str) -> list:
    """A line's text runs (spaces collapsed) and numbers (value, word)."""
    out: list = []
    text = ""
    i = 0
    while i < len(line):
        prev = line[i - 1] if i else ""
        if line[i].isascii() and line[i].isdigit() and not (prev.isalnum() or prev in "._"):  # ASCII: not ² or ₁
            m = _NUMBER.match(line, i)
            word = m.group(0).rstrip(".")
            end = i + len(word)
            nxt = line[end] if end < len(line) else ""
            if not (nxt.isalnum() or nxt == "_"):  # a number, not a hash or a name
                value = float(word)
                if text.endswith("-"):
                    text, value, word = text[:-1], -value, "-" + word
                out.append(" ".join(text.split()) if text.strip() else text.strip())
                out.append((value, word))
                text = ""
                i = end
                continue
            while i < len(line) and (line[i].isalnum() or line[i] == "_"):
                text += line[i]
                i += 1
            continue
        text += line[i]
        i += 1
    out.append(" ".join(text.split()) if text.strip() else text.strip())
    return [p for p in out if p != ""]


def half_ulp(word: str) -> float:
    mantissa, _, exponent = word.lstrip("-").partition("e")
    decimals = len(mantissa.partition(".")[2])
    return 0.5 * 10.0 ** ((int(exponent) if exponent else 0) - decimals)


def mismatch(expected: str, actual: str) -> str | None:
    """Why ``actual`` does not read as ``expected``, if it does not."""
    if expected.endswith("…"):
        expected = expected[:-1]
        actual = actual[: len(expected)]
    e, a = pieces(expected), pieces(actual)
    if len(e) != len(a):
        return f"shape differs: {e} vs {a}"
    for x, y in zip(e, a):
        if isinstance(x, tuple) and isinstance(y, tuple):
            allowed = half_ulp(x[1]) + 0.005 * abs(x[0])
            if abs(x[0] - y[0]) > allowed:
                return f"{x[1]} on the page, {y[1]} from the run (allowed ±{allowed:e})"
        elif x != y:
            return f"{x!r} vs {y!r}"
    return None


def page_says(page: str, phrase: str, values: list) -> None:
    """Fails unless the numbers the page ``page`` (a path from the repository
    root) writes after ``phrase`` read as ``values``, in order, by the rule
    above (``None``: an input or a tolerance, not checked). Words are joined
    by single spaces, so the phrase may cross a line break. The tests that
    measure what a page quotes call this (crates/cli/tests/common/quotes.rs
    is the Rust side)."""
    text = " ".join((ROOT / page).read_text().split())
    phrase = " ".join(phrase.split())
    assert phrase in text, f"{page} lost the words {phrase!r}"
    rest = " " + text[text.index(phrase) + len(phrase) :]  # a number right after the phrase starts after a space
    numbers = [p for p in pieces(rest) if isinstance(p, tuple)][: len(values)]
    assert len(numbers) == len(values), f"{page}: fewer than {len(values)} numbers after {phrase!r}"
    for (written, word), value in zip(numbers, values):
        if value is None:
            continue
        allowed = half_ulp(word) + 0.005 * abs(written)
        assert abs(written - value) <= allowed, f"{page} is stale: after {phrase!r} it says {word}, the code gives {value}"


class PageChecker(doctest.OutputChecker):
    def check_output(self, want: str, got: str, optionflags: int) -> bool:
        w, g = want.splitlines(), got.splitlines()
        return len(w) == len(g) and all(mismatch(x, y) is None for x, y in zip(w, g))


def test_the_comparison_reads_numbers_to_the_digits_shown():
    assert mismatch("total 2.9760 s", "total 2.9761 s") is None
    assert mismatch("total 2.9760 s", "total 3.0100 s")
    assert mismatch("0     0    2.350000e-10", "0  0  2.350000e-10") is None
    assert mismatch("'3413e8028ba7'", "'3413e8028ba7'") is None
    assert mismatch("'3413e8028ba7'", "'3413e8028ba8'")
    assert mismatch("(8, 107)", "(8, 110)")
    assert mismatch("mass -1.5e-7", "mass -1.5e-7") is None
    assert mismatch("mass -1.5e-7", "mass 1.5e-7")
    assert mismatch("<pneumo.Result …", "<pneumo.Result 'x'>") is None


def blocks(page: str) -> list[tuple[str, str]]:
    """The page's fenced blocks: (info string, text)."""
    return re.findall(r"^```([^\n]*)\n(.*?)^```", page, flags=re.M | re.S)


def test_the_python_guide_runs_as_written_and_prints_what_it_shows(tmp_path, monkeypatch):
    page = (ROOT / "docs" / "python.md").read_text(encoding="utf-8")
    slow = os.environ.get("PNEUMO_SLOW_DOCS") == "1"
    sessions = [(info.split(), text) for info, text in blocks(page) if info.split()[:1] == ["python"] and ">>> " in text]
    assert len(sessions) >= 6, f"{len(sessions)} session blocks found in docs/python.md"
    text = "".join(t for words, t in sessions if slow or "slow" not in words)
    (tmp_path / "models").symlink_to(ROOT / "models")
    monkeypatch.chdir(tmp_path)
    parser = doctest.DocTestParser()
    test = doctest.DocTest(parser.get_examples(text), {}, "docs/python.md", str(ROOT / "docs" / "python.md"), 0, text)
    assert len(test.examples) >= 20, f"only {len(test.examples)} lines run"
    runner = doctest.DocTestRunner(checker=PageChecker(), optionflags=doctest.DONT_ACCEPT_TRUE_FOR_1)
    report: list[str] = []
    try:
        runner.run(test, out=report.append, clear_globs=False)
    finally:
        with contextlib.suppress(Exception):
            test.globs.clear()
    failed, tried = runner.summarize(verbose=False)
    assert failed == 0, "docs/python.md is stale (or a line failed):\n" + "".join(report)


def test_the_readme_s_python_runs(tmp_path, monkeypatch):
    page = (ROOT / "README.md").read_text(encoding="utf-8")
    code = [text for info, text in blocks(page) if info.strip() == "python"]
    assert len(code) == 1, "README.md's Python block"
    (tmp_path / "models").symlink_to(ROOT / "models")
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    try:
        exec(compile(code[0], "README.md", "exec"), namespace)
        assert namespace["df"].shape[0] == 4 and namespace["df"]["error"].isna().all()
    finally:
        client = namespace.get("client")
        if client is not None:
            client.close()
            with contextlib.suppress(Exception):
                client.cluster.close()

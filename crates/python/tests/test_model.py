"""Loading, overriding, simulating: the Python API against the command line.

Checked: the summary dict equals ``pneumo simulate --summary``, the traces
equal ``--out`` (NaN where the CSV has an empty cell), overrides by text and
by SI number agree, errors are the CLI's one-line messages in the right
exception classes, an incomplete run warns, models pickle and save, the GIL
is released while simulating and Ctrl-C stops a long run.
"""

from __future__ import annotations

import io
import json
import pickle
import signal
import threading
import time
import warnings

import numpy as np
import pandas as pd
import pytest

import pneumo
from pneumo._sweep import read_csv_exact


def test_the_readme_one_liner_gives_the_first_cycle(meter_out):
    r = pneumo.load(meter_out).simulate(cycles=3)
    first = r.summary["cycles"][0]
    assert {"start_s", "extend_s", "retract_s", "total_s"} <= set(first)
    assert first["start_s"] == 0.0 and 0 < first["extend_s"] < first["total_s"]
    assert len(r.summary["cycles"]) == 3


def test_summary_and_traces_equal_the_command_line(meter_out, cli, tmp_path):
    m = pneumo.load(meter_out).set(**{"supply.p": "6 bar", "flow_control.C": "5 L/min/bar"})
    r = m.simulate(cycles=2)
    s, out = tmp_path / "s.json", tmp_path / "r.csv"
    cli("simulate", str(meter_out), "--set", "supply.p=6 bar", "--set", "flow_control.C=5 L/min/bar", "--cycles", "2",
        "--summary", str(s), "--out", str(out))
    assert r.summary == json.loads(s.read_text())
    # the CSV writer is shared: same bytes
    assert r.to_csv() == out.read_text()
    # and the arrays hold the CSV's numbers, NaN for empty cells
    csv = read_csv_exact(out)
    np.testing.assert_array_equal(r.t, csv["t"].to_numpy())
    for name in r.columns:
        np.testing.assert_array_equal(r[name], csv[name].to_numpy(dtype=float), err_msg=name)
    undefined = [n for n in r.columns if np.isnan(r[n]).any()]
    assert undefined, "some signal (the polytropic index) is undefined at some instants"
    df = r.to_pandas()
    assert df.index.name == "t" and list(df.columns) == r.columns and df.attrs["units"]["head.p"] == "Pa"
    flat = r.to_pandas(time_index=False)
    assert list(flat.columns[:2]) == ["t", r.columns[0]]
    assert r.units["piston.x"] == "m" and r.t.dtype == np.float64 and len(r) == len(csv)


def test_overrides_by_text_and_by_si_number_agree_and_with_params_copies(meter_out):
    m = pneumo.load(meter_out)
    a = m.with_params({"supply.p": "6 bar"})
    b = m.with_params(**{"supply.p": 6e5})
    assert m.sets == [] and a.sets == ["supply.p=6 bar"] and b.sets == ["supply.p=600000.0"]
    assert a.parameters["supply.p"] == b.parameters["supply.p"] == 6e5
    # dependents follow: rod.p0 is chosen by the rest state, piston.p_atm is "= exhaust.p"
    assert a.parameters["piston.p_atm"] == 0.98e5
    ra, rb = a.simulate(cycles=1), b.simulate(cycles=1)
    assert ra.summary["cycles"] == rb.summary["cycles"]
    rest = {(v["component"], v["param"]): v["value"] for v in ra.summary["initial_rest_state"]}
    assert rest[("rod", "p0")] == 6e5 and rest[("head", "p0")] == 0.98e5
    m.set({"piston.mass": "2 kg"}, **{"supply.p": 5e5})
    assert m.sets == ["piston.mass=2 kg", "supply.p=500000.0"] and m.parameters["piston.mass"] == 2.0
    table = m.parameter_table()
    assert table.loc["supply.p", "unit"] == "Pa" and table.loc["bore", "how"] == "parameter"
    assert table.loc["head.orientation", "value"] == "extend"
    assert m.signals["head.p"] == "Pa"


def test_errors_are_the_command_lines_messages_in_their_classes(meter_out, cli_message, tmp_path):
    m = pneumo.load(meter_out)
    with pytest.raises(pneumo.NetlistError) as e:
        m.set(**{"suply.p": "6 bar"})
    assert str(e.value) == cli_message("simulate", str(meter_out), "--set", "suply.p=6 bar")
    assert m.sets == [], "a failed set leaves the model unchanged"
    # a misspelt parameter raises at once, with the command line's did-you-mean
    with pytest.raises(pneumo.NetlistError) as e:
        m.set(**{"supply.pp": "6 bar"})
    assert 'did you mean "p"' in str(e.value)
    assert str(e.value) == cli_message("simulate", str(meter_out), "--set", "supply.pp=6 bar")
    assert m.sets == []
    with pytest.raises(pneumo.NetlistError) as e:
        m.set(**{"supply.p": "6 m"})
    assert str(e.value) == cli_message("simulate", str(meter_out), "--set", "supply.p=6 m")
    missing = tmp_path / "nope.json"
    with pytest.raises(pneumo.NetlistError) as e:
        pneumo.load(missing)
    assert str(e.value) == cli_message("check", str(missing))
    bad = m.with_params(**{"simulation.rtol": 0.5})
    with pytest.raises(pneumo.SimulationError) as e:
        bad.simulate(cycles=1)
    assert str(e.value) == cli_message("simulate", str(meter_out), "--set", "simulation.rtol=0.5", "--cycles", "1")
    with pytest.raises(pneumo.UsageError) as e:
        m.simulate(t_end=-1)
    assert isinstance(e.value, ValueError) and str(e.value) == "--t-end must be > 0 s, got -1"
    assert issubclass(pneumo.DataError, pneumo.PneumoError) and issubclass(pneumo.FileError, OSError)
    with pytest.raises(TypeError):
        m.set(**{"supply.p": True})


def test_an_incomplete_run_warns_and_keeps_its_results(meter_out):
    m = pneumo.load(meter_out).with_params(**{"supply.p": "1 bar", "flow_control.C": "210 L/min/bar"})
    with pytest.warns(pneumo.IncompleteRunWarning, match="only 0 of 2 cycles"):
        r = m.simulate(cycles=2, t_end=5)
    assert r.incomplete.startswith("only 0 of 2 cycles") and r.summary["incomplete"] == r.incomplete
    assert r.t[-1] == pytest.approx(5.0) and r.summary["cycles"] == []


def test_models_pickle_save_and_load_from_text(meter_out, tmp_path):
    m = pneumo.load(meter_out).set(**{"supply.p": "5 bar"})
    back = pickle.loads(pickle.dumps(m))
    assert back.sets == m.sets and back.sha256 == m.sha256 and back.path == m.path
    want = m.simulate(cycles=1).summary["cycles"]
    assert back.simulate(cycles=1).summary["cycles"] == want
    saved = tmp_path / "saved.json"
    m.save(saved)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pneumo.PneumoWarning)  # the saved file holds plain SI numbers
        assert pneumo.load(saved).simulate(cycles=1).summary["cycles"] == want
    text = meter_out.read_text()
    from_text = pneumo.loads(text, name="inline.json")
    assert from_text.sha256 == m.sha256 == __import__("hashlib").sha256(text.encode()).hexdigest()
    # a model carries its files (sub-circuit files too)
    sub = pneumo.load(meter_out.parent / "meter_out_subsystem.json")
    # its cylinder is the built-in component (issue 28): no second file to carry
    assert len(sub.files) == 1 and pickle.loads(pickle.dumps(sub)).files == sub.files


def test_check_reports_like_pneumo_check(meter_out, cli):
    report = pneumo.load(meter_out).check()
    printed = cli("check", str(meter_out)).stdout
    assert printed.startswith(report) and "initial state at rest" in report
    assert "digraph" in pneumo.load(meter_out).to_dot()


def test_the_gil_is_released_while_simulating(meter_out):
    m = pneumo.load(meter_out)
    done = threading.Event()
    result = {}

    def work():
        result["r"] = m.simulate(t_end=15)
        done.set()

    t = threading.Thread(target=work)
    spins = 0
    t.start()
    while not done.is_set():
        spins += 1  # pure Python: runs only while the simulation does not hold the GIL
        sum(range(100))
    t.join()
    assert result["r"].t_final == pytest.approx(15.0)
    assert spins > 1000, f"the main thread ran only {spins} loops during the simulation"


@pytest.mark.parametrize("call", ["m.simulate(t_end=9000)", "pneumo.sweep(m, vary={'supply.p': ['4 bar', '5 bar', '6 bar', '7 bar']}, t_end=9000, jobs=2)"])
def test_ctrl_c_stops_a_long_run(call, python_child):
    code = f"""
import signal, sys, time, pneumo
# a child started from a background job inherits SIGINT ignored; Ctrl-C is
# tested with Python's own handler, as in an interactive session
signal.signal(signal.SIGINT, signal.default_int_handler)
m = pneumo.load("models/meter_out.json").set(**{{"simulation.sample_interval": "100 ms"}})
print("ready", flush=True)
t0 = time.monotonic()
try:
    {call}
except KeyboardInterrupt:
    print(f"interrupted after {{time.monotonic() - t0:.2f}} s", flush=True)
    sys.exit(42)
print("finished", flush=True)
"""
    child = python_child(code)
    assert child.stdout.readline().strip() == "ready"
    time.sleep(1.0)
    sent = time.monotonic()
    child.send_signal(signal.SIGINT)
    try:
        out, err = child.communicate(timeout=30)
    except Exception:
        child.kill()
        raise
    assert child.returncode == 42, f"stdout {out!r} stderr {err!r}"
    assert "interrupted" in out and time.monotonic() - sent < 10


def test_plot_draws_one_panel_per_quantity(meter_out):
    mpl = pytest.importorskip("matplotlib")
    mpl.use("Agg")
    r = pneumo.load(meter_out).simulate(cycles=1)
    fig = r.plot(["head.p", "rod.p", "piston.x"])
    assert len(fig.axes) == 2
    assert fig.axes[0].get_ylabel() == "pressure [bar]" and fig.axes[1].get_ylabel() == "position [mm]"
    line = fig.axes[0].get_lines()[0]
    np.testing.assert_allclose(line.get_ydata(), r["head.p"] * 1e-5)
    import matplotlib.pyplot as plt

    _, ax = plt.subplots()
    assert r.plot(["piston.x"], ax=ax) is ax
    with pytest.raises(KeyError, match="available"):
        r.plot(["head.q"])
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    assert buf.getvalue().startswith(b"\x89PNG")


def test_an_unknown_signal_is_one_short_line_whatever_its_name(meter_out):
    r = pneumo.load(meter_out).simulate(t_end=0.05)
    long = "9" * 400
    with pytest.raises(KeyError) as caught:
        r[long]
    message = str(caught.value)
    assert "(402 characters)" in message and "available: " in message, message
    assert len(message) < 1000 and "9" * 30 not in message, message


def test_python_dash_m_is_the_command_line(cli):
    assert cli("--version").stdout.startswith("pneumo ")
    assert "chamber" in cli("blocks").stdout and "chamber" in pneumo.blocks()
    assert "properties" in pneumo.schema()
    assert cli("simulate", check=False).returncode == 2

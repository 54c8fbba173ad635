"""The discrepancy workflow from Python, on the shipped example (the
meter-out circuit with a hidden piston seal leak of 0.3 L/(min·bar)),
restricted to two candidate effects to stay fast, as the CLI's test."""

from __future__ import annotations

import json
import shutil

import pytest

import pneumo

L_MIN_BAR = 1e-3 / 60 / 1e5


@pytest.fixture
def manifest(root, tmp_path):
    example = root / "models" / "examples" / "discrepancy"
    doc = json.loads((example / "experiments.json").read_text())
    for e in doc["experiments"]:
        shutil.copy(example / e["data"], tmp_path / e["data"])
    doc.update({"effects": ["piston_seal_leak", "valve_delay"], "max_effects": 1})
    path = tmp_path / "experiments.json"
    path.write_text(json.dumps(doc))
    return path


def test_names_the_hidden_leak_and_returns_a_runnable_model(meter_out, manifest, tmp_path):
    found = pneumo.discrepancy(meter_out, manifest, report=tmp_path / "report")
    assert found.effects == ["piston_seal_leak"], found.verdict
    c = found.effect_parameters["piston_seal_leak"]["C"]
    assert abs(c / L_MIN_BAR - 0.3) < 0.03, c / L_MIN_BAR
    est = found.estimates
    assert "piston_seal_leak.C" in est.index and est.loc["piston_seal_leak.C", "ci95_low"] < c < est.loc["piston_seal_leak.C", "ci95_high"]
    # the estimate and its interval side by side in one unit
    row = est.loc["piston_seal_leak.C"]
    assert row["unit"] == "L/min/bar" and row["ci95_low_in_unit"] < row["value_in_unit"] < row["ci95_high_in_unit"]
    assert abs(row["ci95_low_in_unit"] * L_MIN_BAR / row["ci95_low"] - 1.0) < 1e-9
    assert set(found.candidates["effect"]) == {"piston_seal_leak", "valve_delay"}
    assert (found.rmse["after"] < found.rmse["baseline"]).all()
    assert found.summary["verdict"] == found.verdict and "piston_seal_leak" in repr(found)
    # the augmented model runs, with the leak in it
    model = found.model
    assert "piston_seal_leak" in model.to_json() or any(k.startswith("seal") for k in model.parameters)
    r = model.simulate(cycles=1)
    assert len(r.summary["cycles"]) == 1
    names = {p.name for p in (tmp_path / "report").iterdir()}
    assert {"report.md", "summary.json", "model_with_piston_seal_leak.json"} <= names
    assert sorted(found.report_files) == sorted(str(tmp_path / "report" / n) for n in names)


def test_bad_manifests_are_data_errors(meter_out, tmp_path):
    bad = tmp_path / "experiments.json"
    bad.write_text('{"experiments": [')
    with pytest.raises(pneumo.DataError, match="experiments.json"):
        pneumo.discrepancy(meter_out, bad)
    with pytest.raises(pneumo.FileError):
        pneumo.discrepancy(meter_out, tmp_path / "missing.json")


def test_ctrl_c_stops_the_whole_analysis(python_child):
    import signal
    import time

    child = python_child(
        """
import signal, sys, time, pneumo
# a child started from a background job inherits SIGINT ignored; Ctrl-C is
# tested with Python's own handler, as in an interactive session
signal.signal(signal.SIGINT, signal.default_int_handler)
print("ready", flush=True)
try:
    pneumo.discrepancy("models/meter_out.json", "models/examples/discrepancy/experiments.json")
except KeyboardInterrupt:
    print("interrupted", flush=True)
    sys.exit(42)
print("finished", flush=True)
"""
    )
    assert child.stdout.readline().strip() == "ready"
    time.sleep(1.5)
    sent = time.monotonic()
    child.send_signal(signal.SIGINT)
    out, err = child.communicate(timeout=60)
    assert child.returncode == 42, f"stdout {out!r} stderr {err!r}"
    assert time.monotonic() - sent < 10, "every simulation of the analysis is cancelled"


def test_intervals_read_in_the_unit_of_the_value():
    # a conductance: SI 5e-11 m3/(s Pa) is 0.3 L/min/bar; its interval must not print as 0.0 beside it
    from pneumo._discrepancy import _estimates

    si = 1e-3 / 60.0 / 1e5
    entry = {"name": "leak.C", "value": 0.3 * si, "unit": "L/min/bar", "shown": 0.3,
             "std_error": 0.01 * si, "ci95": [0.28 * si, 0.32 * si], "at_bound": False}
    gauge = {"name": "supply.p", "value": 5e5, "unit": "barg", "shown": 3.99, "std_error": 1e3, "ci95": [4.98e5, 5.02e5]}
    df = _estimates([entry, gauge])
    row = df.loc["leak.C"]
    assert row["value_in_unit"] == 0.3
    assert abs(row["std_error_in_unit"] - 0.01) < 1e-12
    assert abs(row["ci95_low_in_unit"] - 0.28) < 1e-12 and abs(row["ci95_high_in_unit"] - 0.32) < 1e-12
    # a unit with an offset is not scaled: no number rather than a wrong one
    assert df.loc["supply.p"]["ci95_low_in_unit"] is None or df.loc["supply.p"]["ci95_low_in_unit"] != df.loc["supply.p"]["ci95_low_in_unit"]


# A user-declared effect (manifest ``user_effects``, docs/discrepancy.md
# "Effects you declare"): the seal leak written as a netlist edit, a
# ``conductance`` between the chambers with its C free, on the shipped
# example (a hidden orifice leak of 0.3 L/(min·bar), ISO 6358 with b = 0.5,
# in data pneumo made). Only the declared effect is tried (``effects: []``), so the
# run takes seconds; the rig-data version of this test is the CLI's
# (crates/cli/tests/discrepancy_user_effects.rs).
SEAL_ORIFICE = {
    "name": "seal_orifice",
    "description": "ISO 6358 orifice across the piston seal",
    "components": [{"id": "seal", "type": "conductance", "params": {"b": 0.5}}],
    "connections": [["head.port", "seal.a"], ["seal.b", "rod.port"]],
    "free": {
        "seal.C": {
            "null": "0 L/min/bar",
            "start": "0.2 L/min/bar",
            # (an upper bound of 5 L/min/bar was once refused here by the
            # nesting check; it now accepts any bounds of an effect that fades
            # continuously into the model, docs/discrepancy.md)
            "bounds": ["0 L/min/bar", "1 L/min/bar"],
            "scan": ["0.03 L/min/bar", "0.3 L/min/bar"],
        }
    },
}


def _declared(root, tmp_path, effect):
    example = root / "models" / "examples" / "discrepancy"
    doc = json.loads((example / "experiments.json").read_text())
    for e in doc["experiments"]:
        shutil.copy(example / e["data"], tmp_path / e["data"])
    doc.update({"effects": [], "max_effects": 1, "user_effects": [effect]})
    path = tmp_path / "experiments.json"
    path.write_text(json.dumps(doc))
    return path


def test_a_declared_effect_is_tried_named_and_sized(meter_out, root, tmp_path):
    found = pneumo.discrepancy(meter_out, _declared(root, tmp_path, SEAL_ORIFICE))
    assert found.effects == ["seal_orifice"], found.verdict
    c = found.effect_parameters["seal_orifice"]["seal.C"]
    # stated up front: within ±10 % of the hidden 0.3 L/(min·bar), the
    # tolerance of the built-in leak on the same data (test above)
    assert abs(c / L_MIN_BAR - 0.3) < 0.03, c / L_MIN_BAR
    assert list(found.candidates["effect"]) == ["seal_orifice"]
    # the augmented model holds the declared component and runs
    assert "seal" in found.model.to_json()
    assert len(found.model.simulate(cycles=1).summary["cycles"]) == 1


def test_a_malformed_declaration_is_refused_naming_the_effect(meter_out, root, tmp_path):
    bad = json.loads(json.dumps(SEAL_ORIFICE))
    bad["free"]["seal.C"]["bounds"] = ["0 bar", "5 bar"]  # a conductance bounded in a pressure unit
    with pytest.raises(pneumo.DataError, match="seal_orifice"):
        pneumo.discrepancy(meter_out, _declared(root, tmp_path, bad))
    unknown = json.loads(json.dumps(SEAL_ORIFICE))
    unknown["connections"] = [["head.port", "seal.a"], ["seal.b", "nowhere.port"]]
    with pytest.raises(pneumo.DataError, match="nowhere"):
        pneumo.discrepancy(meter_out, _declared(root, tmp_path, unknown))

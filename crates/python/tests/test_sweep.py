"""Sweeps from Python against ``pneumo sweep``: the DataFrame holds the CLI's
CSV (same columns, same values), ``out=`` writes its bytes, shards merge with
``pneumo merge``, every row carries the parameters it ran with, and bad
arguments raise the CLI's messages.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

import pneumo
from pneumo._sweep import read_csv_exact

C = ["1.41 L/min/bar", "2.68 L/min/bar", "13.2 L/min/bar", "210 L/min/bar"]
P = ["4 bar", "7 bar"]


def cli_vary(name, values):
    return ["--vary", f"{name}={','.join(values)}"]


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """The Table 1 study (8 cases, 2 cycles) from Python and from the CLI, with a fixed --set."""
    from conftest import METER_OUT, run_cli

    d = tmp_path_factory.mktemp("study")
    m = pneumo.load(METER_OUT).set(**{"piston.mass": "1.5 kg"})
    df = pneumo.sweep(m, vary={"flow_control.C": C, "supply.p": P}, cycles=2, jobs=2, out=d / "py.csv")
    run_cli("sweep", str(METER_OUT), *cli_vary("flow_control.C", C), *cli_vary("supply.p", P), "--set", "piston.mass=1.5 kg",
            "--cycles", "2", "--jobs", "2", "--out", str(d / "cli.csv"))
    return m, df, d


def test_the_dataframe_is_the_command_lines_csv(study):
    m, df, d = study
    cli = read_csv_exact(d / "cli.csv")
    assert len(df) == 8 and list(df.columns) == list(cli.columns)
    pd.testing.assert_frame_equal(df, cli, check_dtype=False, check_exact=True)
    assert (d / "py.csv").read_bytes() == (d / "cli.csv").read_bytes()
    # odometer order, SI values, no failures
    assert list(df["case"]) == list(range(8)) and (df["n_cases"] == 8).all()
    np.testing.assert_array_equal(df["supply.p"], [4e5, 7e5] * 4)
    np.testing.assert_allclose(df["flow_control.C"].iloc[::2], [x * 1e-3 / 60 / 1e5 for x in (1.41, 2.68, 13.2, 210)], rtol=1e-12)
    assert df["error"].isna().all() and df["cycle_time_s"].dtype == np.float64
    # opening the throttle shortens the cycle at both pressures
    for p in (4e5, 7e5):
        assert df[df["supply.p"] == p]["cycle_time_s"].is_monotonic_decreasing


def test_every_row_carries_the_parameters_it_ran_with(study):
    m, df, _ = study
    row = df.iloc[5]
    assert row["model"] == m.path and row["model_sha256"] == m.sha256 and json.loads(row["set"]) == ["piston.mass=1.5 kg"]
    assert row["param:supply.p"] == row["supply.p"] and row["param:flow_control.C"] == row["flow_control.C"]
    assert row["param:piston.mass"] == 1.5 and row["param:bore"] == 0.045 and row["param:head.orientation"] == "extend"
    assert row["param:rod.p0"] == row["supply.p"], "the rest state's initial values are recorded"
    assert row["param:simulation.cycles"] == 2 and row["param:gas.model"] == "ideal"
    params = [c for c in df.columns if c.startswith("param:")]
    assert len(params) > 50
    assert df.attrs["pneumo"]["sets"] == ["piston.mass=1.5 kg"] and df.attrs["pneumo"]["vary"]["supply.p"] == P
    assert df.attrs["units"]["supply.p"] == "Pa" and df.attrs["units"]["cycle_time_s"] == "s"
    assert df.attrs["units"]["param:flow_control.C"] == "m3/(s Pa)" and df.attrs["units"]["head.T_max_K"] == "K"


def test_shards_merge_into_the_whole_with_pneumo_merge(study, cli, tmp_path):
    m, df, d = study
    parts = [pneumo.sweep(m, vary={"flow_control.C": C, "supply.p": P}, cycles=2, shard=f"{k}/3", out=tmp_path / f"s{k}.csv") for k in (1, 2, 3)]
    assert [list(p["case"]) for p in parts] == [[0, 3, 6], [1, 4, 7], [2, 5]]
    joined = pd.concat(parts).sort_values("case").reset_index(drop=True)
    pd.testing.assert_frame_equal(joined, df, check_exact=True)
    cli("merge", *(str(tmp_path / f"s{k}.csv") for k in (3, 1, 2)), "--out", str(tmp_path / "all.csv"))
    assert (tmp_path / "all.csv").read_bytes() == (d / "py.csv").read_bytes()


def test_json_and_parquet_outputs(study, cli, meter_out, tmp_path):
    m, df, d = study
    small = {"supply.p": P}
    pneumo.sweep(m, vary=small, cycles=1, out=tmp_path / "py.json")
    cli("sweep", str(meter_out), *cli_vary("supply.p", P), "--set", "piston.mass=1.5 kg", "--cycles", "1", "--out", str(tmp_path / "cli.json"))
    assert (tmp_path / "py.json").read_bytes() == (tmp_path / "cli.json").read_bytes()
    pytest.importorskip("pyarrow")
    frame = pneumo.sweep(m, vary=small, cycles=1, out=tmp_path / "s.parquet")
    back = pneumo.read_sweep(tmp_path / "s.parquet")
    pd.testing.assert_frame_equal(back, frame, check_dtype=False, check_exact=True)
    assert back.attrs["pneumo"] == json.loads(json.dumps(frame.attrs["pneumo"])) and back.attrs["units"] == frame.attrs["units"]
    from_csv = pneumo.read_sweep(d / "cli.csv")
    assert from_csv.attrs["pneumo"]["model_sha256"] == m.sha256 and from_csv.attrs["pneumo"]["sets"] == ["piston.mass=1.5 kg"]
    from_json = pneumo.read_sweep(tmp_path / "cli.json")
    pd.testing.assert_frame_equal(from_json, frame, check_dtype=False, check_exact=True)


def test_results_do_not_depend_on_threads_and_failures_are_rows(meter_out):
    m = pneumo.load(meter_out).set(**{"flow_control.C": "210 L/min/bar"})
    one = pneumo.sweep(m, vary={"supply.p": ["1 bar", "4 bar", "6 bar"]}, cycles=2, t_end=5, jobs=1)
    two = pneumo.sweep(m, vary={"supply.p": ["1 bar", "4 bar", "6 bar"]}, cycles=2, t_end=5, jobs=2)
    pd.testing.assert_frame_equal(one, two, check_exact=True)
    assert one.loc[0, "error"].startswith("only 0 of 2 cycles") and np.isnan(one.loc[0, "cycle_time_s"])
    assert one["error"].iloc[1:].isna().all() and one.loc[0, "param:supply.p"] == 1e5


def test_numbers_are_si_and_a_single_value_is_one_case(meter_out):
    m = pneumo.load(meter_out)
    by_number = pneumo.sweep(m, vary={"supply.p": [4e5], "piston.mass": 2}, cycles=1)
    by_text = pneumo.sweep(m, vary={"supply.p": "4 bar", "piston.mass": ["2 kg"]}, cycles=1)
    assert len(by_number) == 1
    cols = [c for c in by_text.columns if c not in ("model", "model_sha256")]
    pd.testing.assert_frame_equal(by_number[cols], by_text[cols], check_exact=True)
    # numpy arrays and pandas Series are lists of values too
    arrays = pneumo.sweep(m, vary={"supply.p": np.array([4e5, 5e5]), "piston.mass": pd.Series([2.0])}, cycles=1)
    np.testing.assert_array_equal(arrays["supply.p"], [4e5, 5e5])
    assert arrays.loc[0, "cycle_time_s"] == by_number.loc[0, "cycle_time_s"]


def test_bad_arguments_raise_the_command_lines_messages(meter_out, cli_message):
    m = pneumo.load(meter_out)
    cases = [
        ({"suply.p": ["4 bar"]}, ["--vary", "suply.p=4 bar"]),
        ({"supply.pressure": ["4 bar"]}, ["--vary", "supply.pressure=4 bar"]),
        ({"supply.p": ["4 bar", "7 m"]}, ["--vary", "supply.p=4 bar,7 m"]),
        ({"gas.model": ["ideal", "vdw"]}, ["--vary", "gas.model=ideal,vdw"]),
    ]
    for vary, args in cases:
        with pytest.raises(pneumo.UsageError) as e:
            pneumo.sweep(m, vary=vary)
        assert str(e.value) == cli_message("sweep", str(meter_out), *args), vary
    with pytest.raises(pneumo.UsageError, match="--shard"):
        pneumo.sweep(m, vary={"supply.p": P}, shard="3/2")
    with pytest.raises(pneumo.UsageError, match="--max-cases"):
        pneumo.sweep(m, vary={"supply.p": P, "piston.mass": ["1 kg", "2 kg"]}, max_cases=3)
    with pytest.raises(pneumo.UsageError):
        pneumo.sweep(m, vary={})
    with pytest.raises(ValueError):
        pneumo.sweep(m, vary={"supply.p": [float("nan")]})

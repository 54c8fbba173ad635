"""Sweeps on a real Dask cluster: a ``LocalCluster`` of two worker processes
runs the cases (each worker imports pneumo itself; the model travels with the
tasks) and the DataFrame equals the local sweep's, bit for bit."""

from __future__ import annotations

import os
import shutil

import pandas as pd
import pytest

import pneumo

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=40)
    c = distributed.Client(cluster)
    try:
        yield c
    finally:
        c.close()
        cluster.close()


def test_a_dask_sweep_equals_the_local_one(client, meter_out, tmp_path):
    pids = set(client.run(os.getpid).values())
    assert len(pids) == 2 and os.getpid() not in pids, "workers are separate processes"
    # a copy of the model that is deleted before the sweep: workers never read the file
    copy = tmp_path / "meter_out.json"
    shutil.copy(meter_out, copy)
    m = pneumo.load(copy).set(**{"piston.mass": "1.5 kg"})
    copy.unlink()
    vary = {"flow_control.C": ["1.41 L/min/bar", "2.68 L/min/bar", "13.2 L/min/bar", "210 L/min/bar"], "supply.p": ["4 bar", "7 bar"]}
    local = pneumo.sweep(m, vary=vary, cycles=2, out=tmp_path / "local.csv")
    remote = pneumo.sweep(m, vary=vary, cycles=2, client=client, out=tmp_path / "dask.csv")
    assert len(remote) == 8 and remote["error"].isna().all()
    pd.testing.assert_frame_equal(remote, local, check_exact=True)
    assert remote.attrs == local.attrs
    assert (tmp_path / "dask.csv").read_bytes() == (tmp_path / "local.csv").read_bytes()
    # every case ran on a worker
    ran = client.run(lambda: len(__import__("pneumo._sweep", fromlist=["_PLANS"])._PLANS))
    assert sum(ran.values()) >= 1


def test_a_dask_shard_and_failed_cases(client, meter_out):
    m = pneumo.load(meter_out).set(**{"flow_control.C": "210 L/min/bar"})
    vary = {"supply.p": ["1 bar", "4 bar", "5 bar", "6 bar"]}
    local = pneumo.sweep(m, vary=vary, cycles=2, t_end=5, shard=(2, 2))
    remote = pneumo.sweep(m, vary=vary, cycles=2, t_end=5, shard="2/2", client=client)
    pd.testing.assert_frame_equal(remote, local, check_exact=True)
    assert list(remote["case"]) == [1, 3]
    everything = pneumo.sweep(m, vary=vary, cycles=2, t_end=5, client=client)
    assert everything.loc[0, "error"].startswith("only 0 of 2 cycles")
    with pytest.raises(pneumo.UsageError, match="jobs"):
        pneumo.sweep(m, vary=vary, client=client, jobs=2)

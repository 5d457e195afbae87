"""Executors: a Dask cluster simulates exactly what this process does, and loses no design to a dead worker."""

from __future__ import annotations

import os

import numpy as np
import pandas as pd
import pytest

from hevlib import doe
from hevlib.params import ParamsError, load_params
from hevlib.sim.executor import DaskExecutor, LocalExecutor, executor_for
from hevlib.sim.simulator import Simulator


@pytest.fixture(scope="module")
def dask_sim(lib, params):
    """The simulator on a 2-worker LocalCluster (started on first use, closed after the module)."""
    cfg = params.model_copy(update={"sim": params.sim.model_copy(update={"executor": "dask", "workers": 2})})
    with Simulator(lib, cfg) as s:
        yield s


@pytest.fixture(scope="module")
def designs(params):
    return doe.lhs_designs(params.design_space.space(), 24, seed=7)


def test_params_choose_the_executor(params):
    assert isinstance(executor_for(params.sim), LocalExecutor)
    dask_ex = executor_for(params.sim.model_copy(update={"executor": "dask", "scheduler": "tcp://h:8786"}))
    assert isinstance(dask_ex, DaskExecutor) and dask_ex.scheduler == "tcp://h:8786" and dask_ex._client is None


def test_scheduler_without_dask_is_refused(tmp_path, root):
    text = (root / "params.yaml").read_text().replace("  soc_init: 0.7", "  scheduler: tcp://h:8786\n  soc_init: 0.7")
    path = tmp_path / "params.yaml"
    path.write_text(text)
    with pytest.raises(ParamsError, match="scheduler"):
        load_params(path)


def test_where_batches_run_is_not_part_of_the_fingerprint(params):
    other = params.model_copy(update={"sim": params.sim.model_copy(update={"executor": "dask", "workers": 3})})
    assert doe.simulation_fingerprint(other) == doe.simulation_fingerprint(params)
    changed = params.model_copy(update={"sim": params.sim.model_copy(update={"ambient_c": 0.0})})
    assert doe.simulation_fingerprint(changed) != doe.simulation_fingerprint(params)


def test_dask_doe_parquet_is_byte_identical(sim, dask_sim, designs, cycles, params, tmp_path):
    """The DOE table of a 2-worker LocalCluster (6 batches as tasks) equals the local one byte for byte."""
    udds = cycles["udds"]
    files = {}
    for name, s in (("local", sim), ("dask", dask_sim)):
        seen: list[int] = []
        table = doe.simulate_designs(
            s, designs, "lhs", udds, batch_size=4, progress=lambda d, _, seen=seen: seen.append(d)
        )
        assert seen[-1] == len(designs) and sorted(seen) == seen  # progress counts designs up to all of them
        files[name] = tmp_path / f"{name}.parquet"
        doe.write_doe(files[name], table, doe.run_metadata(udds, s.params, method="lhs"))
    assert dask_sim.executor.name == "dask" and dask_sim.executor._cluster is not None
    assert files["dask"].read_bytes() == files["local"].read_bytes()


def test_a_worker_killed_mid_run_loses_no_design(sim, dask_sim, params, cycles):
    """Kill a worker that holds tasks as soon as the first batch is back: every design still comes back,
    equal to the local run, in order."""
    X = doe.lhs_designs(params.design_space.space(), 96, seed=11)
    cyc = cycles["udds"]
    ex = dask_sim.executor
    ex.client.wait_for_workers(2)
    before = set(ex.client.scheduler_info()["workers"])
    killed: list[str] = []

    async def die() -> None:  # defined here so that it travels by value; async: run without waiting
        os._exit(1)

    def kill_once(done: int, total: int) -> None:
        if killed:
            return
        busy = [w for w, keys in ex.client.processing().items() if keys]
        if busy:
            killed.append(busy[0])
            ex.client.run(die, workers=[busy[0]], wait=False)

    got = dask_sim.run(X, cyc, batch_size=4, progress=kill_once)
    assert killed, "no worker was busy after the first batch: the test did not kill one"
    assert killed[0] in before and killed[0] not in set(ex.client.scheduler_info()["workers"])
    want = sim.run(X, cyc, batch_size=4)
    assert len(got) == len(X)
    pd.testing.assert_frame_equal(got, want, check_exact=True)
    assert np.array_equal(got["fc"].to_numpy(), want["fc"].to_numpy())


def test_a_stage_closes_its_cluster(lib, params):
    cfg = params.model_copy(update={"sim": params.sim.model_copy(update={"executor": "dask", "workers": 1})})
    s = Simulator(lib, cfg)
    s.executor.client  # noqa: B018  (starts the LocalCluster)
    cluster = s.executor._cluster
    s.close()
    assert s.executor._client is None and cluster.status.name == "closed"

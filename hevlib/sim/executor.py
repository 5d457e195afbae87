"""Executors: where batches of designs are simulated (this process, or a Dask cluster).

Every batch the pipeline simulates (DOE, held-out set, re-simulation, oracle, infill rounds, validation)
goes through :meth:`hevlib.sim.simulator.Simulator.run`, which splits the designs into batches and hands them
to its executor's :meth:`map`. Batches are independent (each design is simulated on its own), so where
they run cannot change a result: the results come back in batch order and are concatenated exactly as
the local executor concatenates them.

- :class:`LocalExecutor`: batches one after another in this process (the kernels use every core).
- :class:`DaskExecutor`: batches as Dask tasks on a cluster (``sim.scheduler``: its address) or on a
  ``LocalCluster`` the executor starts and closes itself (``sim.scheduler`` unset). The simulator is
  sent to the workers once per executor (scattered, broadcast); each task is one batch. A worker that
  dies mid-run loses nothing: the scheduler reassigns the tasks it held (``allowed-failures``) and a
  task whose own code failed is retried (``retries``) before the run fails.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from typing import Any, Protocol

#: Re-assignments of a task whose worker died (Dask's ``distributed.scheduler.allowed-failures``) and
#: resubmissions of a task that raised, before the run fails.
TASK_RETRIES = 3

Progress = Callable[[int, int], None]


class Executor(Protocol):
    def map(self, fn: Callable, payload: Any, items: Sequence, sizes: Sequence[int], progress: Progress | None) -> list:
        """``[fn(payload, item) for item in items]`` in order; ``progress(n_done, n_total)`` counts ``sizes``."""

    def close(self) -> None: ...


class LocalExecutor:
    """Batches in this process, in order."""

    name = "local"

    def map(self, fn, payload, items, sizes, progress=None) -> list:
        out, done, total = [], 0, int(sum(sizes))
        for item, n in zip(items, sizes, strict=True):
            out.append(fn(payload, item))
            done += int(n)
            if progress is not None:
                progress(done, total)
        return out

    def close(self) -> None:
        pass


def _threads_task(fn, payload, item, n_threads):
    """Run one batch on a worker with the numba thread pool sized to the worker's share of the cores."""
    import numba

    numba.set_num_threads(max(1, min(int(n_threads), numba.config.NUMBA_NUM_THREADS)))
    return fn(payload, item)


class DaskExecutor:
    """Batches as Dask tasks. ``scheduler``: a scheduler address (``tcp://host:8786``); ``None`` starts a
    ``LocalCluster`` of ``n_workers`` single-threaded worker processes (default: one per core), closed by
    :meth:`close`. The cluster starts on the first :meth:`map`."""

    name = "dask"

    def __init__(self, scheduler: str | None = None, n_workers: int | None = None):
        self.scheduler = scheduler
        self.n_workers = n_workers
        self._client = None
        self._cluster = None
        self._scattered: dict[int, Any] = {}
        self._kernel_threads: int | None = None  # per task, asked of the cluster once (_threads_per_worker)

    @property
    def client(self):
        if self._client is None:
            import dask
            from distributed import Client, LocalCluster

            dask.config.set({"distributed.scheduler.allowed-failures": TASK_RETRIES})
            if self.scheduler is None:
                n = self.n_workers or os.cpu_count() or 1
                self._cluster = LocalCluster(
                    n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0", silence_logs=40
                )
                self._client = Client(self._cluster)
            else:
                self._client = Client(self.scheduler)
        return self._client

    def _threads_per_worker(self) -> int:
        """Threads for the kernels in each task: a machine's cores shared among the workers on it (the
        smallest share over the cluster)."""
        cores = self.client.run(os.cpu_count)  # {worker address: cores of its machine}
        hosts = self.client.scheduler_info()["workers"]
        per_host: dict[str, int] = {}
        for addr in cores:
            host = hosts[addr]["host"]
            per_host[host] = per_host.get(host, 0) + 1
        return max(1, min((cores[a] or 1) // per_host[hosts[a]["host"]] for a in cores)) if cores else 1

    def map(self, fn, payload, items, sizes, progress=None) -> list:
        from distributed import as_completed

        client = self.client
        key = id(payload)
        if key not in self._scattered:
            self._scattered[key] = (payload, client.scatter(payload, broadcast=True, hash=False))
        remote = self._scattered[key][1]
        if self._kernel_threads is None:
            self._kernel_threads = self._threads_per_worker()
        n_threads = self._kernel_threads
        futures = [
            client.submit(_threads_task, fn, remote, item, n_threads, pure=False, retries=TASK_RETRIES)
            for item in items
        ]
        index = {f.key: i for i, f in enumerate(futures)}
        done, total = 0, int(sum(sizes))
        out: list = [None] * len(futures)
        for fut in as_completed(futures):
            i = index[fut.key]
            out[i] = fut.result()
            done += int(sizes[i])
            if progress is not None:
                progress(done, total)
        return out

    def close(self) -> None:
        if self._client is not None:
            self._client.close()
            self._client = None
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None
        self._scattered.clear()
        self._kernel_threads = None


def executor_for(sim_params) -> LocalExecutor | DaskExecutor:
    """The executor ``params.sim`` asks for (``executor``, ``scheduler``, ``workers``)."""
    if sim_params.executor == "dask":
        return DaskExecutor(sim_params.scheduler, sim_params.workers)
    return LocalExecutor()

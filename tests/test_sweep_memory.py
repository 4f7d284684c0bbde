"""Sweep workers keep no statistical profile: Dask's profiler (on by default) samples the task thread
every 10 ms and keeps one call tree per 1 s cycle for the last 1000 cycles, which made worker memory grow
cell after cell (docs/sweep.md, "Scale"). The LocalCluster the sweep starts has it off.

A task runs Python for 1.5 s (more than one profile cycle); with the profiler on, the worker would hold
at least one history entry and a non-zero sample count afterwards.
"""
import time

import pytest

pytest.importorskip("dask.distributed")

from sim.app.sweep.driver import _client, import_dask      # noqa: E402


def _busy(seconds: float) -> int:
    n, t_end = 0, time.perf_counter() + seconds
    while time.perf_counter() < t_end:
        n += sum(range(100))
    return n


def _profile_state(dask_worker) -> dict:
    return {"callbacks": sorted(k for k in dask_worker.periodic_callbacks if k.startswith("profile")),
            "history": len(dask_worker.profile_history), "recent_samples": dask_worker.profile_recent["count"]}


def test_local_cluster_workers_keep_no_profile():
    Client, LocalCluster, _ = import_dask()
    with _client(Client, LocalCluster, 1, None) as client:
        client.submit(_busy, 1.5, pure=False).result()
        (state,) = client.run(_profile_state).values()
    assert state == {"callbacks": [], "history": 0, "recent_samples": 0}

"""The sweep engine: blocks of points as Dask tasks, results stored as they arrive.

Where it runs: a ``LocalCluster`` of one single-threaded worker process per core by
default; an existing cluster when ``scheduler`` (``tcp://HOST:PORT``) or Dask's own
``DASK_SCHEDULER_ADDRESS`` names one (its workers need drill_twin installed); or, with
``scheduler='inline'``, the calling process (the reference the tests compare against).

Each worker compiles (or loads from numba's cache) the kernels once, before the first
task (``Client.run``); a task is a block of points that share that compiled model, sized
so that the scheduler's cost per task stays a small fraction of the task
(:func:`block_points_for`).  The spec is sent to each worker once (``scatter``).
"""
from __future__ import annotations

import logging
import os
import time
from dataclasses import dataclass

from ..physics.parameters import ParameterError
from .evaluate import evaluate_block
from .spec import SweepSpec
from .store import SweepStore

__all__ = ['run_sweep', 'SweepReport', 'block_points_for', 'TARGET_TASK_S', 'INLINE']

#: wall time a task should take: ~100x the scheduler's per-task cost (a few ms)
TARGET_TASK_S = 0.5
#: ``scheduler`` value that evaluates in the calling process
INLINE = 'inline'


@dataclass
class SweepReport:
    """What a run did: ``computed`` blocks (this run), ``skipped`` (found done), ``wall_s``
    from the first submission to the last result, ``compute_s`` summed over the tasks,
    ``workers``; ``efficiency`` = compute / (wall × workers) and ``overhead_per_task_s``."""

    computed: int
    skipped: int
    wall_s: float
    compute_s: float
    workers: int
    out: str = ''

    @property
    def efficiency(self) -> float:
        return self.compute_s / (self.wall_s * self.workers) if self.wall_s > 0 else 1.0

    @property
    def overhead_per_task_s(self) -> float:
        if not self.computed:
            return 0.0
        return max(0.0, self.wall_s * self.workers - self.compute_s) / self.computed

    def as_dict(self) -> dict:
        return {'out': self.out, 'blocks_computed': self.computed,
                'blocks_skipped': self.skipped, 'workers': self.workers,
                'wall_s': round(self.wall_s, 3), 'compute_s': round(self.compute_s, 3),
                'parallel_efficiency': round(self.efficiency, 4),
                'overhead_per_task_ms': round(1e3 * self.overhead_per_task_s, 3)}


def block_points_for(spec: SweepSpec, seconds_per_point: float, workers: int) -> int:
    """Points per task: about :data:`TARGET_TASK_S` of work, at least four tasks per
    worker when the grid allows; linear sweeps in whole lines of ``x`` where a line is
    shorter than a task (the root seeds run along a line)."""
    per_task = max(1, round(TARGET_TASK_S / max(seconds_per_point, 1e-6)))
    per_task = min(per_task, max(1, spec.points // (4 * max(workers, 1))))
    if spec.kind == 'linear' and not spec.samples and per_task >= spec.x.size:
        per_task = (per_task // spec.x.size) * spec.x.size
    return per_task


def run_sweep(spec: SweepSpec, out, scheduler: str | None = None,
              workers: int | None = None, progress=None) -> SweepReport:
    """Compute the blocks of ``spec`` not yet in ``out``, store each as it arrives, write
    ``out/sweep.nc`` at the end (also when interrupted).  ``progress(fraction)`` is called
    as blocks arrive, with a detail line 'k/N blocks'."""
    store = SweepStore(out, spec)
    store.begin_run()
    done = store.done()
    todo = [b for b in range(spec.blocks) if b not in done]
    tick = _progress(progress, len(done), spec.blocks)
    try:
        if scheduler == INLINE:
            report = _inline(spec, store, todo, tick)
        else:
            report = _on_dask(spec, store, todo, tick, scheduler, workers)
    finally:
        store.write_dataset()
    report.skipped, report.out = len(done), str(store.out)
    return report


def _progress(progress, already, total):
    count = [already]

    def tick():
        count[0] += 1
        if progress is not None:
            progress(count[0] / total, f'{count[0]}/{total} blocks')
    if progress is not None:
        progress(already / total, f'{already}/{total} blocks' + (' (resumed)' if already
                                                                  else ''))
    return tick


def _inline(spec, store, todo, tick) -> SweepReport:
    t0, compute = time.perf_counter(), 0.0
    for block in todo:
        result = evaluate_block(spec, block)
        store.save(result)
        compute += result['compute_s']
        tick()
    return SweepReport(len(todo), 0, time.perf_counter() - t0, compute, 1)


def _on_dask(spec, store, todo, tick, scheduler, workers) -> SweepReport:
    from dask.distributed import as_completed
    with _DaskClient(scheduler, workers) as client:
        n_workers = len(client.scheduler_info()['workers'])
        if n_workers == 0:
            raise ParameterError(f'the Dask cluster at {scheduler} has no workers')
        client.run(_warm, spec)     # numba: compiled (or loaded) once per worker
        shared = client.scatter(spec, broadcast=True)
        t0, compute = time.perf_counter(), 0.0
        futures = client.map(_task, todo, spec=shared, pure=False)
        try:
            for future in as_completed(futures):
                result = future.result()
                store.save(result)
                compute += result['compute_s']
                tick()
        finally:
            client.cancel(futures)
        return SweepReport(len(todo), 0, time.perf_counter() - t0, compute, n_workers)


def _task(block: int, spec: SweepSpec):
    return evaluate_block(spec, block)


def _warm(spec: SweepSpec) -> None:
    """Compile or load the kernels the sweep uses, in a worker, before its first task."""
    from ..physics.scenario import scenario_from_dict, with_values
    from ..physics.simulation import Simulation
    if spec.kind == 'linear':
        evaluate_block(spec, 0)
        return
    try:
        sc = scenario_from_dict(with_values(spec.raw, spec.values_at(0)), 'sweep')
    except ParameterError:
        return
    Simulation.from_scenario(sc).warm_up()


class _DaskClient:
    """A Dask client: of the cluster at ``scheduler`` (or ``DASK_SCHEDULER_ADDRESS``), or of a
    local cluster of ``workers`` single-threaded processes (default: one per core)."""

    def __init__(self, scheduler, workers):
        self.address = scheduler or os.environ.get('DASK_SCHEDULER_ADDRESS')
        self.workers = workers or os.cpu_count()
        self.cluster = self.client = None

    def __enter__(self):
        from dask.distributed import Client, LocalCluster
        if self.address:
            try:
                self.client = Client(self.address, timeout='20s')
            except OSError as exc:
                raise ParameterError(f'no Dask scheduler at {self.address}: {exc}') from None
            return self.client
        self.cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1,
                                    processes=True, dashboard_address=None,
                                    silence_logs=logging.CRITICAL)
        self.client = Client(self.cluster)
        return self.client

    def __exit__(self, *exc):
        # closing races the workers' last heartbeats: their 'stream closed' reports are
        # the shutdown itself, not errors
        logging.getLogger('distributed').setLevel(logging.CRITICAL)
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()
        return False

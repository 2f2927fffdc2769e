"""The sweep engine: blocks of points as Dask tasks, results stored as they arrive.

Where it runs: a ``LocalCluster`` of one single-threaded worker process per core by
default; an existing cluster when ``scheduler`` (``tcp://HOST:PORT``) or Dask's own
``DASK_SCHEDULER_ADDRESS`` names one (its workers need drill_twin installed); or, with
``scheduler='inline'``, the calling process (the reference the tests compare against).

Where it runs is checked before any work (:func:`check_executor`: the form of the
address, the number of workers) and the scheduler is reached before anything is written
(:func:`connect`): a TCP connection within :data:`CONNECT_TIMEOUT_S`, Dask's greeting
within :data:`GREETING_TIMEOUT_S` (a server of another kind is refused before Dask's
client reads its answer as a message length), the client within
:data:`CLIENT_TIMEOUT_S`.

Each worker compiles (or loads from numba's cache) the kernels once, before the first
task (``Client.run``); a task is a block of points that share that compiled model, sized
so that the scheduler's cost per task stays a small fraction of the task
(:func:`block_points_for`).  The spec is sent to each worker once (``scatter``).
"""
from __future__ import annotations

import contextlib
import logging
import os
import re
import socket
import struct
import sys
import time
from dataclasses import dataclass

from ..errors import ParameterError
from .evaluate import evaluate_block
from .spec import MAX_BLOCKS, SweepSpec
from .store import SweepStore

__all__ = ['run_sweep', 'SweepReport', 'block_points_for', 'check_executor', 'connect',
           'TARGET_TASK_S', 'INLINE']

#: wall time a task should take: ~100x the scheduler's per-task cost (a few ms)
TARGET_TASK_S = 0.5
#: ``scheduler`` value that evaluates in the calling process
INLINE = 'inline'
#: Dask's own variable naming a scheduler
ENV_ADDRESS = 'DASK_SCHEDULER_ADDRESS'
#: a scheduler address: tcp:// or tls://, a host name, IPv4 or [IPv6] address, a port
_ADDRESS = re.compile(r'^(tcp|tls)://([A-Za-z0-9_.-]{1,253}|\[[0-9A-Fa-f:.]{2,45}\]):'
                      r'(\d{1,5})$')
#: most worker processes of a local cluster, per core (more only add memory)
WORKERS_PER_CORE = 4
#: seconds to open a TCP connection to a scheduler
CONNECT_TIMEOUT_S = 5.0
#: seconds for a scheduler to greet (Dask's listener writes its handshake at once)
GREETING_TIMEOUT_S = 5.0
#: longest the greeting's read blocks at once [s] (the process answers a signal that often)
GREETING_SLICE_S = 0.1
#: a greeting's length prefix above this [bytes] is not Dask's handshake (~200 bytes)
MAX_GREETING_BYTES = 2 ** 20
#: seconds for Dask's client to connect, and to close a client or a local cluster
CLIENT_TIMEOUT_S = 10.0


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
    shorter than a task (the root seeds run along a line); never more than
    :data:`~drill_twin.sweep.spec.MAX_BLOCKS` blocks."""
    per_task = max(1, round(TARGET_TASK_S / max(seconds_per_point, 1e-6)))
    per_task = min(per_task, max(1, spec.points // (4 * max(workers, 1))))
    if spec.kind == 'linear' and not spec.samples and per_task >= spec.x.size:
        per_task = (per_task // spec.x.size) * spec.x.size
    return max(per_task, -(-spec.points // MAX_BLOCKS))


# --- where the blocks run ---------------------------------------------------------------
def check_executor(scheduler: str | None, workers: int | None) -> str | None:
    """The scheduler a sweep uses — None (a local cluster), :data:`INLINE` or a checked
    ``tcp://HOST:PORT`` (``scheduler``, else ``$DASK_SCHEDULER_ADDRESS``) — and
    ``workers`` checked: one-line errors, before any work."""
    if scheduler is not None:
        address, where = scheduler.strip(), '--scheduler'
        if not address:
            raise ParameterError("--scheduler '': give inline or tcp://HOST:PORT (without "
                                 '--scheduler: a local cluster)')
    else:
        address, where = os.environ.get(ENV_ADDRESS, '').strip() or None, ENV_ADDRESS
    if address is not None and not (address == INLINE and where == '--scheduler'):
        _split_address(address, where)
    if workers is not None:
        most = WORKERS_PER_CORE * (os.cpu_count() or 1)
        if not 1 <= workers <= most:
            raise ParameterError(f'--workers {workers}: must be in [1, {most}] ({WORKERS_PER_CORE} '
                                 'per core; a larger cluster: --scheduler tcp://HOST:PORT)')
        if address is not None:
            raise ParameterError(f'--workers {workers} is the size of a local cluster: not '
                                 f'with {where} {address}')
    return address


def _split_address(address: str, where: str) -> tuple[str, str, int]:
    m = _ADDRESS.match(address)
    port = int(m.group(3)) if m else 0
    if not m or not 1 <= port <= 65535:
        inline = 'inline or ' if where == '--scheduler' else ''
        raise ParameterError(f'{where} {address!r}: not {inline}tcp://HOST:PORT (or '
                             'tls://HOST:PORT; port 1-65535)')
    return m.group(1), m.group(2).strip('[]'), port


@contextlib.contextmanager
def connect(address: str | None, workers: int | None = None):
    """An executor of blocks at ``address`` (of :func:`check_executor`): the calling
    process (:data:`INLINE`), a Dask cluster there, or a local cluster of ``workers``
    processes (default: one per core); closed on leaving, within bounded time."""
    if address == INLINE:
        yield _Inline()
        return
    with _DaskClient(address, workers) as client:
        yield _Dask(client, address)


class _Inline:
    """Blocks evaluated one after the other in this process."""

    workers = 1

    def prepare(self, spec: SweepSpec) -> None:
        pass

    def results(self, spec: SweepSpec, todo):
        for block in todo:
            yield evaluate_block(spec, block)


class _Dask:
    """Blocks as Dask tasks of ``client``'s cluster."""

    def __init__(self, client, address):
        self.client = client
        self.workers = len(client.scheduler_info()['workers'])
        if self.workers == 0:
            raise ParameterError(f'the Dask cluster at {address} has no workers')
        self.shared = None

    def prepare(self, spec: SweepSpec) -> None:
        self.client.run(_warm, spec)     # numba: compiled (or loaded) once per worker
        self.shared = self.client.scatter(spec, broadcast=True)

    def results(self, spec: SweepSpec, todo):
        from dask.distributed import as_completed
        futures = self.client.map(_task, todo, spec=self.shared, pure=False)
        try:
            for future in as_completed(futures):
                yield future.result()
        finally:
            self.client.cancel(futures)


# --- a run ------------------------------------------------------------------------------
def run_sweep(spec: SweepSpec, out, scheduler: str | None = None,
              workers: int | None = None, progress=None, executor=None,
              notice=None) -> SweepReport:
    """Compute the blocks of ``spec`` not yet in ``out``, store each as it arrives, write
    ``out/sweep.nc`` at the end (also when interrupted or failed).

    Parameters
    ----------
    scheduler, workers
        Where the blocks run (:func:`check_executor`), unless ``executor`` (of
        :func:`connect`) is given.
    progress : callable, optional
        ``progress(fraction, detail)`` as blocks arrive ('k/N blocks').
    notice : callable, optional
        ``notice(line)`` once for each file of ``blocks/`` that is not a finished block
        (default: a line on stderr).
    """
    if executor is None:
        address = check_executor(scheduler, workers)
        SweepStore(out, spec)                 # a directory it may not use: refused first
        with connect(address, workers) as executor:
            return run_sweep(spec, out, progress=progress, executor=executor,
                             notice=notice)
    store = SweepStore(out, spec)
    done, problems = store.scan()
    for line in problems:
        (notice or _stderr)(line)
    todo = [b for b in range(spec.blocks) if b not in done]
    store.make_room(todo)
    store.begin_run()
    tick = _progress(progress, len(done), spec.blocks)
    try:
        executor.prepare(spec)
        wall, compute = _compute(spec, store, executor, todo, tick)
    except BaseException:
        with contextlib.suppress(ParameterError):   # (the first failure is the one told)
            store.write_dataset()
        raise
    store.write_dataset()
    return SweepReport(len(todo), len(done), wall, compute, executor.workers, str(store.out))


def _compute(spec, store, executor, todo, tick) -> tuple[float, float]:
    """Evaluate ``todo`` on ``executor``, storing each block: (wall, compute) [s]."""
    t0, compute = time.perf_counter(), 0.0
    results = executor.results(spec, todo)
    try:
        for result in results:
            store.save(result)
            compute += result['compute_s']
            tick()
    finally:
        results.close()
    return time.perf_counter() - t0, compute


def _stderr(line: str) -> None:
    print(f'drill-twin sweep: {line}', file=sys.stderr, flush=True)


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


def _task(block: int, spec: SweepSpec):
    return evaluate_block(spec, block)


def _warm(spec: SweepSpec) -> None:
    """Compile or load the kernels the sweep uses, in a worker, before its first task."""
    from ..config.scenario import scenario_from_dict, with_values
    from ..physics.simulation import Simulation
    if spec.kind == 'linear':
        evaluate_block(spec, 0)
        return
    try:
        sc = scenario_from_dict(with_values(spec.raw, spec.values_at(0)), 'sweep')
    except ParameterError:
        return
    Simulation.from_scenario(sc).warm_up()


# --- Dask -------------------------------------------------------------------------------
def _greeting(host: str, port: int, address: str) -> None:
    """Reach ``host:port`` and read the length prefix of Dask's handshake, which its
    listener sends unasked: a one-line error unless it is plausible."""
    try:
        sock = socket.create_connection((host, port), timeout=CONNECT_TIMEOUT_S)
    except OSError as exc:
        raise ParameterError(f'no Dask scheduler at {address}: '
                             f'{exc.strerror or exc or type(exc).__name__}') from None
    with sock:
        head = _read_greeting(sock)
    length = struct.unpack('<Q', head)[0] if len(head) == 8 else 0
    if not 0 < length <= MAX_GREETING_BYTES:
        said = f'answered {head[:8]!r}' if head else \
            f'said nothing within {GREETING_TIMEOUT_S:g} s'
        raise ParameterError(f'{address} is not a Dask scheduler (a server there {said}, '
                             "not Dask's handshake)")


def _read_greeting(sock) -> bytes:
    """Up to 8 bytes from ``sock`` within :data:`GREETING_TIMEOUT_S`, read in slices of
    :data:`GREETING_SLICE_S`, so that the main thread is back in Python — where a pending
    signal's handler runs — at least every slice, also for a signal that did not interrupt
    the ``recv`` itself (one delivered to another thread, or while unblocking)."""
    deadline = time.monotonic() + GREETING_TIMEOUT_S
    sock.settimeout(GREETING_SLICE_S)
    head = b''
    while len(head) < 8 and time.monotonic() < deadline:
        try:
            chunk = sock.recv(8 - len(head))
        except TimeoutError:
            continue
        except OSError:
            break
        if not chunk:
            break
        head += chunk
    return head


class _DaskClient:
    """A Dask client: of the cluster at ``address``, or of a local cluster of ``workers``
    single-threaded processes (default: one per core)."""

    def __init__(self, address, workers):
        self.address = address
        self.workers = workers or os.cpu_count()
        self.cluster = self.client = None

    def __enter__(self):
        from dask.distributed import Client, LocalCluster
        if self.address:
            scheme, host, port = _split_address(self.address, 'the scheduler')
            if scheme == 'tcp':
                _greeting(host, port, self.address)
            try:
                self.client = Client(self.address, timeout=f'{CLIENT_TIMEOUT_S}s')
            except Exception as exc:     # distributed fails in many ways: each is one line
                raise ParameterError(f'no Dask scheduler at {self.address}: '
                                     f'{type(exc).__name__}: {exc}') from None
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
            self.client.close(timeout=CLIENT_TIMEOUT_S)
        if self.cluster is not None:
            self.cluster.close(timeout=CLIENT_TIMEOUT_S)
        return False

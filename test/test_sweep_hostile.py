"""A sweep's hostile surroundings, beyond its command lines (those are the corpus
test/data/hostile/sweep.yaml): a sweep directory with a corrupt or stray block file
resumes to the result of an uninterrupted sweep and names the file it recomputed or
ignored; a spec.json that cannot be read is refused and left as it was; a server that is
not a Dask scheduler is refused in bounded time, reading no length from it, and a signal
ends the wait; a full disk (a real 1 MB tmpfs) and writes that fail with ENOSPC or
EACCES are one error, leave no temporary file and a directory the same command resumes;
a grid, an axis or a sample count that is too large is refused before it is allocated."""
import errno
import io
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from drill_twin.cli import main
from drill_twin.config.scenario import load_scenario
from drill_twin.errors import ParameterError
from drill_twin.sweep import INLINE, Axis, SweepSpec, SweepStore, engine, parse_axis, run_sweep
from drill_twin.sweep.spec import parse_distribution

RGD2_SET = ['groups.psi=13.79', 'groups.n_b=4', 'groups.n_b_lambda=4']
RGD2 = load_scenario('rgd2_stick_slip', RGD2_SET).raw
RGD = load_scenario('rgd_stick_slip').raw
#: the small linear sweep of these tests: 8 x 3 points in 6 blocks of 4
X, Y, BLOCK = 'groups.omega_o:1:40:8', 'upsilon_o:0.05:4:3', 4
#: the same sweep on the command line
ARGV = ['sweep', '--config', 'rgd2_stick_slip', *[a for s in RGD2_SET for a in ('--set', s)],
        '--x', X, '--y', Y, '--threshold', '1e-3', '--scheduler', INLINE]


def small_spec(block=BLOCK):
    return SweepSpec(RGD2, 'linear', parse_axis(X), parse_axis(Y), block_points=block,
                     threshold=1e-3)


def netcdf(out) -> dict:
    """The arrays of ``out/sweep.nc`` but ``run`` (which run computed a point)."""
    with xr.open_dataset(Path(out) / 'sweep.nc', engine='scipy') as ds:
        return {k: ds[k].values.copy() for k in ds.data_vars if k != 'run'}


def runs(out) -> np.ndarray:
    with xr.open_dataset(Path(out) / 'sweep.nc', engine='scipy') as ds:
        return ds['run'].values.copy()


def same(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for k in a:
        assert np.array_equal(a[k], b[k], equal_nan=True), k


def listing(folder) -> dict:
    return {str(p.relative_to(folder)): (p.stat().st_mtime_ns, p.stat().st_size)
            for p in sorted(Path(folder).rglob('*'))}


@pytest.fixture(scope='module')
def finished(tmp_path_factory):
    """An uninterrupted sweep: (its directory, its netCDF arrays)."""
    out = tmp_path_factory.mktemp('finished') / 'sweep'
    report = run_sweep(small_spec(), out, scheduler=INLINE)
    assert report.computed == small_spec().blocks == 6
    return out, netcdf(out)


@pytest.fixture()
def copy(finished, tmp_path):
    out = tmp_path / 'sweep'
    shutil.copytree(finished[0], out)
    return out


def resume(out):
    """Run the sweep on ``out`` again: (report, the lines it reported)."""
    lines = []
    return run_sweep(small_spec(), out, scheduler=INLINE, notice=lines.append), lines


# --- corrupt and stray block files ------------------------------------------------------
def _npz(path, **arrays):
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    path.write_bytes(buffer.getvalue())


def _npy(array) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


def _huge_header(path):
    """An npz whose abscissa claims 10^12 values (8 TB) in a file of a few bytes."""
    header = {'descr': '<f8', 'fortran_order': False, 'shape': (10 ** 12,)}
    npy = io.BytesIO()
    np.lib.format.write_array_header_1_0(npy, header)
    with zipfile.ZipFile(path, 'w') as zf:
        zf.writestr('abscissa.npy', npy.getvalue() + b'\0' * 64)
        zf.writestr('unstable.npy', npy.getvalue())
        zf.writestr('run.npy', npy.getvalue())


GOOD = dict(run=np.int32(1), abscissa=np.zeros(BLOCK), unstable=np.zeros(BLOCK, np.int32))
CORRUPTIONS = {
    'truncated': lambda p: p.write_bytes(p.read_bytes()[: p.stat().st_size // 2]),
    'empty': lambda p: p.write_bytes(b''),
    'random bytes': lambda p: p.write_bytes(np.random.default_rng(1).bytes(700)),
    'wrong shape': lambda p: _npz(p, **dict(GOOD, abscissa=np.zeros(BLOCK + 1))),
    'missing array': lambda p: _npz(p, run=GOOD['run'], abscissa=GOOD['abscissa']),
    'text array': lambda p: _npz(p, **dict(GOOD, abscissa=np.array(['a'] * BLOCK))),
    'object array': lambda p: _npz(p, **dict(GOOD, abscissa=np.array([None] * BLOCK))),
    'float counts': lambda p: _npz(p, **dict(GOOD, unstable=np.zeros(BLOCK))),
    'run of no run': lambda p: _npz(p, **dict(GOOD, run=np.int32(7))),
    'a .npy, not an .npz': lambda p: p.write_bytes(_npy(GOOD['abscissa'])),
    'a directory': lambda p: (p.unlink(), p.mkdir()),
    'a header asking for 8 TB': _huge_header,
}


@pytest.mark.parametrize('block', range(6))
def test_any_one_truncated_block_is_recomputed_to_the_uninterrupted_result(finished, copy,
                                                                           block):
    CORRUPTIONS['truncated'](copy / 'blocks' / f'{block:06d}.npz')
    report, lines = resume(copy)
    assert (report.computed, report.skipped) == (1, 5)
    assert len(lines) == 1 and f'{block:06d}.npz: ' in lines[0], lines
    assert 'computing the block again' in lines[0]
    same(netcdf(copy), finished[1])
    recomputed = np.zeros(24, dtype=bool)
    recomputed[block * BLOCK:(block + 1) * BLOCK] = True
    assert np.array_equal(runs(copy).ravel(), np.where(recomputed, 2, 1))


@pytest.mark.parametrize('corrupt', CORRUPTIONS.values(), ids=CORRUPTIONS.keys())
def test_each_kind_of_corrupt_block_is_named_and_recomputed(finished, copy, corrupt):
    tracemalloc.start()
    try:
        corrupt(copy / 'blocks' / '000002.npz')
        report, lines = resume(copy)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert (report.computed, report.skipped) == (1, 5)
    assert len(lines) == 1 and '000002.npz' in lines[0], lines
    same(netcdf(copy), finished[1])
    assert peak < 50e6        # no allocation a header asks for


def test_files_that_are_not_blocks_are_named_and_ignored(finished, copy):
    blocks = copy / 'blocks'
    shutil.copy(blocks / '000001.npz', blocks / 'abc.npz')
    shutil.copy(blocks / '000001.npz', blocks / '000099.npz')     # beyond the grid
    (blocks / 'notes.txt').write_text('mine')
    (blocks / '000001.tmp').write_bytes(b'half a block')           # a write a kill cut
    report, lines = resume(copy)
    assert (report.computed, report.skipped) == (0, 6)
    assert sorted(Path(line.split(':')[0]).name for line in lines) == [
        '000099.npz', 'abc.npz', 'notes.txt']
    assert all('not a block of this sweep' in line and 'ignored' in line for line in lines)
    assert not (blocks / '000001.tmp').exists()
    same(netcdf(copy), finished[1])


def test_the_command_resumes_a_corrupt_block_and_says_which(tmp_path, capsys):
    out = tmp_path / 'sweep'
    argv = ARGV + ['--block', str(BLOCK), '--out', str(out)]
    assert main(argv) == 0
    first = netcdf(out)
    capsys.readouterr()
    (out / 'blocks' / '000003.npz').write_bytes(b'PK\3\4 not a block')
    assert main(argv) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and '000003.npz' in err[0] and 'computing the block again' in err[0]
    same(netcdf(out), first)
    assert main(argv) == 0          # reported once: the file is whole again
    assert capsys.readouterr().err.strip() == ''


# --- spec.json ------------------------------------------------------------------------
BAD_SPECS = {
    'truncated': lambda text: text[: len(text) // 2],
    'empty': lambda text: '',
    'without spec': lambda text: json.dumps({'runs': 1}),
    'runs a word': lambda text: json.dumps(dict(json.loads(text), runs='three')),
    'runs a fraction': lambda text: json.dumps(dict(json.loads(text), runs=1.5)),
    'runs negative': lambda text: json.dumps(dict(json.loads(text), runs=-1)),
    'a list': lambda text: json.dumps([json.loads(text)]),
    'binary': lambda text: np.random.default_rng(2).bytes(300),
    'spec without a field': lambda text: json.dumps(dict(json.loads(text), spec={
        k: v for k, v in json.loads(text)['spec'].items() if k != 'draws'})),
    'axis values text': lambda text: text.replace('"values": [1.0', '"values": ["1.0"'),
    'block_points zero': lambda text: text.replace('"block_points": 4', '"block_points": 0'),
    'raw not a configuration': lambda text: json.dumps(dict(json.loads(text), spec=dict(
        json.loads(text)['spec'], raw={'units': 'si'}))),
    'nested 100000 deep': lambda text: '[' * 100_000,
}


@pytest.mark.parametrize('make', BAD_SPECS.values(), ids=BAD_SPECS.keys())
def test_an_unreadable_spec_json_is_refused_and_left_as_it_was(copy, make):
    meta = copy / 'spec.json'
    bad = make(meta.read_text())
    meta.write_bytes(bad if isinstance(bad, bytes) else bad.encode())
    before = listing(copy)
    with pytest.raises(ParameterError, match='spec.json') as info:
        SweepStore(copy, small_spec())
    assert len(str(info.value).splitlines()) == 1
    with pytest.raises(ParameterError, match='spec.json'):
        resume(copy)
    assert listing(copy) == before


# --- schedulers -----------------------------------------------------------------------
class _Server:
    """A TCP server on loopback that greets each connection with ``greeting`` (b'': says
    nothing) and keeps it open."""

    def __init__(self, greeting: bytes):
        self.sock = socket.create_server(('127.0.0.1', 0))
        self.address = f'tcp://127.0.0.1:{self.sock.getsockname()[1]}'
        self.greeting, self.open, self.accepted = greeting, [], threading.Event()
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.open.append(conn)
            self.accepted.set()
            if self.greeting:
                conn.sendall(self.greeting)

    def close(self):
        self.sock.close()
        for conn in self.open:
            conn.close()


@pytest.fixture()
def server(request):
    s = _Server(request.param)
    yield s
    s.close()


@pytest.mark.parametrize('server', [b'HTTP/1.0 400 Bad request\r\n\r\n', b''],
                         indirect=True, ids=['speaks first', 'silent'])
def test_a_server_that_is_not_dask_is_refused_in_bounded_time(server):
    tracemalloc.start()
    t0 = time.monotonic()
    try:
        with pytest.raises(ParameterError, match='not a Dask scheduler'):
            with engine.connect(engine.check_executor(server.address, None)):
                pass
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert time.monotonic() - t0 < engine.GREETING_TIMEOUT_S + 5
    assert peak < 10e6        # 'HTTP/1.0' is not read as a length of 3.5e18 bytes


@pytest.mark.parametrize('server', [b''], indirect=True)
def test_a_signal_ends_the_wait_for_a_greeting(server, monkeypatch):
    monkeypatch.setattr(engine, 'GREETING_TIMEOUT_S', 120.0)

    def interrupt(signum, frame):
        raise KeyboardInterrupt
    previous = signal.signal(signal.SIGALRM, interrupt)
    t0 = time.monotonic()
    try:
        signal.setitimer(signal.ITIMER_REAL, 0.5)
        with pytest.raises(KeyboardInterrupt):
            with engine.connect(server.address):
                pass
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert time.monotonic() - t0 < 5


#: ``drill-twin ARGS`` with the signal state a terminal's shell gives a command: Ctrl-C's
#: default handler and nothing blocked.  A child inherits an ignored SIGINT and the signal
#: mask from this worker, whose earlier tests (nodes, executors) may have changed them: once
#: in a loaded full run the sweep ignored the SIGINT and ended only at the greeting timeout.
AS_FROM_A_SHELL = ('import runpy, signal, sys; '
                   'signal.signal(signal.SIGINT, signal.default_int_handler); '
                   'signal.pthread_sigmask(signal.SIG_UNBLOCK, [signal.SIGINT, signal.SIGTERM]); '
                   "sys.argv[0] = 'drill-twin'; runpy.run_module('drill_twin.cli', "
                   "run_name='__main__')")


@pytest.mark.timeout(120)
@pytest.mark.parametrize('signum', [signal.SIGTERM, signal.SIGINT], ids=['SIGTERM', 'SIGINT'])
@pytest.mark.parametrize('server', [b''], indirect=True)
def test_a_signal_ends_a_sweep_waiting_for_a_scheduler(server, tmp_path, signum):
    out = tmp_path / 'out'
    argv = [a for a in ARGV if a not in ('--scheduler', INLINE)]
    proc = subprocess.Popen([sys.executable, '-c', AS_FROM_A_SHELL, *argv, '--block', '4',
                             '--scheduler', server.address, '--out', str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert server.accepted.wait(60), 'the sweep never reached the scheduler'
        proc.send_signal(signum)
        t0 = time.monotonic()
        _, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert time.monotonic() - t0 < engine.GREETING_TIMEOUT_S - 1, err
    assert proc.returncode == 130 and err.strip() == 'drill-twin: interrupted', err
    assert not out.exists()


# --- a full disk ----------------------------------------------------------------------
@pytest.fixture()
def small_disk():
    """A 1 MB tmpfs (root and permission to mount needed, else skipped)."""
    folder = Path(tempfile.mkdtemp(prefix='drill_twin_disk_'))
    done = subprocess.run(['mount', '-t', 'tmpfs', '-o', 'size=1m', 'tmpfs', str(folder)],
                          capture_output=True, text=True)
    if done.returncode != 0:
        folder.rmdir()
        pytest.skip(f'cannot mount a tmpfs here: {done.stderr.strip() or done.returncode}')
    try:
        yield folder
    finally:
        subprocess.run(['umount', '-l', str(folder)], check=False)
        shutil.rmtree(folder, ignore_errors=True)


def _fill(folder: Path, leave: int) -> Path:
    """A file that leaves ``leave`` bytes of ``folder``'s filesystem free."""
    st = os.statvfs(folder)
    filler = folder / 'filler'
    filler.write_bytes(b'\0' * max(0, st.f_bavail * st.f_frsize - leave))
    return filler


#: what the full disk leaves free: the spec and a few of the 24 one-point blocks
#: (tmpfs gives each file whole pages)
FREE_BYTES = 10 * 4096


@pytest.mark.timeout(300)
def test_a_full_disk_is_one_line_and_the_sweep_resumes_when_there_is_space(small_disk,
                                                                           tmp_path, capsys):
    out = small_disk / 'sweep'
    argv = ARGV + ['--block', '1']
    filler = _fill(small_disk, FREE_BYTES)
    assert main(argv + ['--out', str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'No space left on device' in err[0], err
    assert 'resumes' in err[0]
    assert not [p for p in small_disk.rglob('*') if p.name.endswith('.tmp')]
    stored = len(list((out / 'blocks').glob('*.npz')))
    assert 0 < stored < 24
    filler.unlink()
    assert main(argv + ['--out', str(out)]) == 0
    assert main(argv + ['--out', str(tmp_path / 'fresh')]) == 0
    same(netcdf(out), netcdf(tmp_path / 'fresh'))
    assert (runs(out) == 1).sum() == stored and (runs(out) == 2).sum() == 24 - stored


def _failing_fsync(monkeypatch, code: int, at: int):
    """``os.fsync`` of the store fails with ``code`` at its ``at``-th call (1: the spec;
    2-7: the blocks; 8: sweep.nc)."""
    calls = [0]
    real = os.fsync

    def fsync(fd):
        calls[0] += 1
        if calls[0] == at:
            raise OSError(code, os.strerror(code))
        real(fd)
    monkeypatch.setattr('drill_twin.sweep.store.os.fsync', fsync)


@pytest.mark.parametrize('code', [errno.ENOSPC, errno.EACCES], ids=['ENOSPC', 'EACCES'])
@pytest.mark.parametrize('at', [1, 4, 8], ids=['spec.json', 'a block', 'sweep.nc'])
def test_a_failed_write_leaves_no_temporary_file_and_a_directory_that_resumes(
        finished, tmp_path, monkeypatch, code, at):
    out = tmp_path / 'sweep'
    _failing_fsync(monkeypatch, code, at)
    with pytest.raises(ParameterError, match=os.strerror(code)) as info:
        run_sweep(small_spec(), out, scheduler=INLINE)
    monkeypatch.undo()
    assert len(str(info.value).splitlines()) == 1
    assert not [p for p in tmp_path.rglob('*') if p.name.endswith('.tmp')]
    if at == 1:
        assert not out.exists()          # a new directory is removed again
    report, lines = resume(out)
    assert lines == [] and report.computed == {1: 6, 4: 4, 8: 0}[at]
    same(netcdf(out), finished[1])


# --- bounds before allocation ---------------------------------------------------------
BIG = {
    'an axis of 1e9 values': lambda: parse_axis('groups.omega_o:1:2:1000000000'),
    'a grid of 1e10 points': lambda: SweepSpec(
        RGD, 'linear', parse_axis('groups.omega_o:1:2:100000'),
        parse_axis('groups.W_o:6:8:100000')),
    'a billion samples': lambda: SweepSpec(
        RGD, 'nonlinear', Axis('groups.omega_o', (5.0,)), duration=10.0, samples=10 ** 9,
        vary=(parse_distribution('groups.beta=uniform(0.2,0.5)'),)),
    '2e6 blocks': lambda: SweepSpec(RGD, 'linear', parse_axis('groups.omega_o:1:2:100000'),
                                    parse_axis('groups.W_o:6:8:20'), block_points=1),
}


@pytest.mark.parametrize('make', BIG.values(), ids=BIG.keys())
def test_sizes_are_refused_before_anything_is_allocated(make):
    tracemalloc.start()
    t0 = time.monotonic()
    try:
        with pytest.raises(ParameterError):
            make()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 30e6 and time.monotonic() - t0 < 5


# --- the spec as the engine's other callers make it ---------------------------------
@pytest.mark.parametrize('make, words', [
    (lambda: SweepSpec(RGD, 'linear', Axis('nope.key', (1.0, 2.0))), 'unknown key nope'),
    (lambda: SweepSpec(RGD, 'linear', Axis('groups.omega_o', (1.0, 2.0)),
                       Axis('groups.omeg', (1.0,))), 'did you mean groups.omega_o'),
    (lambda: SweepSpec(RGD, 'linear', Axis('groups.omega_o', (-1.0, 2.0))),
     'groups.omega_o = -1.0'),
    (lambda: SweepSpec(RGD, 'linear', Axis('model.elements', (10.0, 20.0))),
     'does not apply'),
    (lambda: Axis('groups.omega_o', (1.0, float('nan'))), 'finite'),
    (lambda: Axis('groups.omega_o', (1.0, 1.0)), 'distinct'),
    (lambda: SweepSpec(RGD, 'nonlinear', Axis('upsilon_o', (0.1, 1.0)), duration=10.0),
     'linear sweeps only'),
], ids=['unknown key', 'did you mean', 'invalid value', 'ignored key', 'nan', 'repeated',
        'upsilon nonlinear'])
def test_a_spec_made_in_code_is_checked_too(make, words):
    with pytest.raises(ParameterError, match=words):
        make()


@pytest.mark.parametrize('spec', [
    small_spec(),
    SweepSpec(RGD, 'nonlinear', parse_axis('groups.omega_o:3:12:3'), duration=40.0,
              settle=20.0, stats=('severity', 'rop_mean'), block_points=2),
    SweepSpec(RGD, 'nonlinear', parse_axis('groups.omega_o:3:12:3'), duration=40.0,
              settle=20.0, samples=5, seed=2 ** 63, vary=(
                  parse_distribution('groups.beta=lognormal(0.3,0.2)'),
                  parse_distribution('groups.psi=normal(50,2)'))),
], ids=['linear', 'nonlinear', 'Monte Carlo'])
def test_a_stored_spec_reads_back_as_the_same_spec(spec):
    assert SweepSpec.from_json(spec.to_json()) == spec

"""Parameter sweeps on Dask (drill_twin.sweep): a real multi-process cluster on loopback
gives the in-process results point for point; a killed sweep resumes without recomputing
finished blocks; Monte Carlo statistics against numpy on the stored samples; hostile
input gets one line and exit code 2."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from drill_twin.config.scenario import load_scenario
from drill_twin.errors import ParameterError
from drill_twin.stability.charts import stability_chart
from drill_twin.sweep import (
    INLINE,
    Axis,
    SweepSpec,
    SweepStore,
    parse_axis,
    parse_distribution,
    run_sweep,
)

RGD2 = load_scenario('rgd2_stick_slip', ['groups.psi=13.79', 'groups.n_b=4',
                                         'groups.n_b_lambda=4']).raw
RGD = load_scenario('rgd_stick_slip').raw


def linear_spec(block=25):
    return SweepSpec(RGD2, 'linear', parse_axis('groups.omega_o:1:40:25'),
                     parse_axis('upsilon_o:0.05:4:6'), block_points=block, threshold=1e-3)


def nonlinear_spec(block=2, **kw):
    return SweepSpec(RGD, 'nonlinear', parse_axis('groups.omega_o:3:12:3'),
                     parse_axis('groups.W_o:6:8:2'), duration=40.0, settle=20.0,
                     block_points=block, **kw)


def monte_carlo_spec():
    return nonlinear_spec(block=3, samples=4, seed=7,
                          vary=(parse_distribution('groups.beta=uniform(0.2,0.5)'),))


def _same(a, b):
    assert a.keys() == b.keys()
    for k in a:
        assert np.array_equal(a[k], b[k], equal_nan=True), k


@pytest.fixture(scope='module')
def dask_cluster(tmp_path_factory):
    """A scheduler process and two single-threaded worker processes on loopback."""
    pytest.importorskip('distributed')
    folder = tmp_path_factory.mktemp('dask')
    file = folder / 'scheduler.json'
    dask = [sys.executable, '-m', 'dask']
    procs = [subprocess.Popen(dask + ['scheduler', '--host', '127.0.0.1', '--port', '0',
                                      '--no-dashboard', '--scheduler-file', str(file)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        deadline = time.monotonic() + 60
        while not file.is_file() and time.monotonic() < deadline:
            time.sleep(0.05)   # polling for the file (a condition with a deadline)
        address = json.loads(file.read_text())['address']
        for _ in range(2):
            procs.append(subprocess.Popen(
                dask + ['worker', address, '--nthreads', '1', '--nworkers', '1',
                        '--no-dashboard'], stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL))
        from dask.distributed import Client
        with Client(address, timeout='30s') as client:
            client.wait_for_workers(2, timeout=120)
        yield address
    finally:
        for p in procs:
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()


@pytest.mark.timeout(900)
@pytest.mark.parametrize('make', [linear_spec, nonlinear_spec, monte_carlo_spec])
def test_a_multi_process_cluster_gives_the_in_process_results(dask_cluster, tmp_path, make):
    spec = make()
    local = run_sweep(spec, tmp_path / 'inline', scheduler=INLINE)
    remote = run_sweep(spec, tmp_path / 'dask', scheduler=dask_cluster)
    assert remote.workers == 2 and remote.computed == local.computed == spec.blocks
    a = SweepStore(tmp_path / 'inline', spec).arrays()
    b = SweepStore(tmp_path / 'dask', spec).arrays()
    del a['run'], b['run']
    _same(a, b)
    assert all(np.isfinite(v).any() for v in a.values())


def test_the_linear_sweep_is_the_stability_chart():
    """The sweep's linear points are the charts' own computation (same roots, same counts)."""
    spec = linear_spec()
    chart = stability_chart(RGD2, spec.x.key, np.array(spec.x.values), spec.y.key,
                            np.array(spec.y.values), workers=1, threshold=1e-3)
    from drill_twin.sweep.evaluate import evaluate_block
    rows = [evaluate_block(spec, b) for b in range(spec.blocks)]
    abscissa = np.concatenate([r['abscissa'] for r in rows]).reshape(spec.shape)
    unstable = np.concatenate([r['unstable'] for r in rows]).reshape(spec.shape)
    assert np.array_equal(unstable, chart.unstable)
    assert np.allclose(abscissa, chart.abscissa, rtol=0, atol=1e-10, equal_nan=True)
    assert 0 < (unstable == 0).mean() < 1   # the chart has a boundary in it


@pytest.mark.timeout(900)
def test_a_killed_sweep_resumes_without_recomputing_finished_blocks(tmp_path):
    out = tmp_path / 'sweep'
    args = [sys.executable, '-m', 'drill_twin.cli', 'sweep', '--config', 'rgd_stick_slip',
            '--x', 'groups.omega_o:3:12:4', '--y', 'groups.W_o:6:8:3', '--kind', 'nonlinear',
            '--duration', '40', '--block', '1', '--scheduler', 'inline', '--out', str(out)]
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    blocks = out / 'blocks'
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and len(list(blocks.glob('*.npz'))) < 3:
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.02)   # polling the directory (a condition with a deadline)
    proc.send_signal(signal.SIGKILL)
    proc.communicate()
    first = {p.name: p.stat().st_mtime_ns for p in blocks.glob('*.npz')}
    assert 3 <= len(first) < 12
    stored = json.loads((out / 'spec.json').read_text())
    spec = SweepSpec.from_json(json.dumps(stored['spec']))
    report = run_sweep(spec, out, scheduler=INLINE)
    assert report.skipped == len(first) and report.computed == 12 - len(first)
    assert {p.name: p.stat().st_mtime_ns for p in blocks.glob('*.npz')
            if p.name in first} == first
    arrays = SweepStore(out, spec).arrays()
    assert sorted(np.unique(arrays['run'])) == [1, 2]
    assert (arrays['run'] == 1).sum() == len(first)
    fresh = run_sweep(spec, tmp_path / 'fresh', scheduler=INLINE)
    assert fresh.computed == 12
    again = SweepStore(tmp_path / 'fresh', spec).arrays()
    del again['run'], arrays['run']
    _same(arrays, again)


def test_monte_carlo_quantiles_and_probability_of_stick_slip(tmp_path):
    spec = monte_carlo_spec()
    run_sweep(spec, tmp_path, scheduler=INLINE)
    ds = SweepStore(tmp_path, spec).dataset()
    draws = np.random.default_rng(7).uniform(0.2, 0.5, 4)   # the documented draw
    assert np.array_equal(ds['draw:groups.beta'].values, draws)
    sf = ds['stick_fraction'].values          # (y, x, sample)
    assert sf.shape == (2, 3, 4)
    assert np.array_equal(ds['stick_slip_probability'].values, (sf > 0).mean(axis=-1))
    assert np.allclose(ds['severity_q50'].values, np.median(ds['severity'].values, axis=-1))
    assert np.allclose(ds['severity_q95'].values,
                       np.quantile(ds['severity'].values, 0.95, axis=-1))
    # each sample is the plain nonlinear run at its drawn beta
    single = SweepSpec(dict(RGD, groups=dict(RGD['groups'], omega_o=spec.x.values[1],
                                             W_o=spec.y.values[0])), 'nonlinear',
                       Axis('groups.beta', (float(draws[2]),)),
                       duration=40.0, settle=20.0)
    run_sweep(single, tmp_path / 'single', scheduler=INLINE)
    value = SweepStore(tmp_path / 'single', single).arrays()['severity'][0, 0]
    assert value == ds['severity'].values[0, 1, 2]


def test_a_different_sweep_in_the_same_directory_is_refused(tmp_path):
    run_sweep(linear_spec(block=50), tmp_path, scheduler=INLINE)
    with pytest.raises(ParameterError, match='different sweep'):
        SweepStore(tmp_path, linear_spec(block=30))


@pytest.mark.parametrize('bad, words', [
    (['--x', 'groups.omega_o:1:x:3'], 'KEY:MIN:MAX:N'),
    (['--x', 'groups.omega_o:1:4:0'], 'N = 0'),
    (['--x', 'groups.omega_o:1:4:3', '--kind', 'nonlinear'], '--duration'),
    (['--x', 'groups.omega_o:1:4:3', '--kind', 'nonlinear', '--duration', '10',
      '--stat', 'speed'], 'not a statistic'),
    (['--x', 'groups.omega_o:1:4:3', '--samples', '3', '--vary', 'groups.beta=normal(1,-1)'],
     'STD > 0'),
    (['--x', 'groups.omega_o:1:4:3', '--samples', '3', '--vary', 'groups.beta=gauss(1,1)'],
     'uniform'),
    (['--x', 'groups.omega_o:1:4:3', '--samples', '3'], '--vary'),
    (['--x', 'groups.omega_o:1:4:3', '--scheduler', 'tcp://127.0.0.1:9'], 'no Dask scheduler'),
    (['--x', 'groups.omega_o:1:4:3', '--samples', '3', '--vary', 'groups.beta=uniform(0.2,0.5)',
      '--seed', '-1'], '--seed'),
    (['--x', 'groups.omega_o:1:4:100000', '--y', 'groups.W_o:1:4:100000'], 'split the sweep'),
    (['--x', 'groups.omega_o:1:4:3', '--workers', '0'], '--workers'),
    (['--x', 'groups.omega_o:1:4:3', '--kind', 'nonlinear', '--duration', 'nan'], 'duration'),
])
def test_bad_sweep_input_is_one_line_and_exit_code_2(tmp_path, bad, words):
    proc = subprocess.run([sys.executable, '-m', 'drill_twin.cli', 'sweep', '--config',
                           'rgd_stick_slip', '--out', str(tmp_path / 'out'), '--block', '5']
                          + bad, capture_output=True, text=True, timeout=120,
                          env=dict(os.environ, DASK_SCHEDULER_ADDRESS=''))
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and words in lines[0], proc.stderr
    assert not Path(tmp_path / 'out' / 'sweep.nc').exists() or 'scheduler' in words

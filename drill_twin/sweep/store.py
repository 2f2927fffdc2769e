"""Where a sweep keeps its results: a directory that survives a kill.

``OUT/spec.json``
    The :class:`~drill_twin.sweep.spec.SweepSpec` (points, blocks, draws) and the number
    of runs that worked on it.
``OUT/blocks/NNNNNN.npz``
    One file per finished block, written as it arrives (to a temporary name, then renamed:
    a kill leaves whole blocks or none), with the run that computed it.
``OUT/sweep.nc``
    The self-describing result (xarray → netCDF): every output over the grid axes (named by
    their configuration keys, values as coordinates), the run that computed each point,
    the spec in the attributes; Monte Carlo sweeps also the quantiles over the samples and
    the probability of stick-slip.  Rewritten whenever a run ends, interrupted or not.

A sweep started again on the same ``OUT`` with the same spec computes only the blocks
that have no file; a different spec is refused.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ..physics.parameters import ParameterError
from .spec import SweepSpec

__all__ = ['SweepStore', 'QUANTILES', 'stored_spec', 'holds_other_sweep']

#: quantiles of a Monte Carlo sweep's statistics over the samples
QUANTILES = (0.05, 0.5, 0.95)


def stored_spec(out) -> dict | None:
    """The spec mapping kept in ``out/spec.json`` (None if ``out`` holds no sweep)."""
    meta = Path(out) / 'spec.json'
    return json.loads(meta.read_text())['spec'] if meta.is_file() else None


def holds_other_sweep(out, spec: SweepSpec) -> bool:
    """Whether ``out`` holds a sweep other than ``spec``."""
    stored = stored_spec(out)
    return stored is not None and json.dumps(stored, sort_keys=True) != spec.to_json()


class SweepStore:
    """The result directory of one sweep (see module docstring).  Reading
    (:meth:`done`, :meth:`arrays`, :meth:`dataset`) changes nothing; a run that computes
    starts with :meth:`begin_run`."""

    def __init__(self, out, spec: SweepSpec):
        self.out = Path(out)
        self.spec = spec
        self.blocks_dir = self.out / 'blocks'
        if holds_other_sweep(self.out, spec):
            raise ParameterError(f'{self.out} holds a different sweep (spec.json): give '
                                 'another --out, or remove it to start again')
        meta = self.out / 'spec.json'
        if not meta.is_file() and self.out.exists() and any(self.out.iterdir()):
            raise ParameterError(f'{self.out} exists and is not a sweep directory')
        self.run = int(json.loads(meta.read_text())['runs']) if meta.is_file() else 0

    def begin_run(self) -> int:
        """Count a new run (the number its blocks carry) and record the spec."""
        self.run += 1
        self.blocks_dir.mkdir(parents=True, exist_ok=True)
        _atomic_write(self.out / 'spec.json', json.dumps(
            {'spec': json.loads(self.spec.to_json()), 'runs': self.run}).encode())
        return self.run

    def done(self) -> set[int]:
        """Blocks with a file (finished in this run or an earlier one)."""
        return {int(p.stem) for p in self.blocks_dir.glob('*.npz')} \
            if self.blocks_dir.is_dir() else set()

    def save(self, result) -> None:
        """Store one block's result as it arrives."""
        block = int(result['block'])
        arrays = {k: np.asarray(result[k]) for k in self.spec.outputs}
        path = self.blocks_dir / f'{block:06d}.npz'
        tmp = path.with_suffix('.tmp')
        with open(tmp, 'wb') as f:
            np.savez(f, run=np.int32(self.run), compute_s=float(result['compute_s']), **arrays)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)

    def arrays(self) -> dict:
        """Every output over the grid (NaN / -1 where not computed yet) and ``run``."""
        spec = self.spec
        flat = {k: np.full(spec.points, -1 if k == 'unstable' else np.nan,
                           dtype=np.int32 if k == 'unstable' else float)
                for k in spec.outputs}
        flat['run'] = np.zeros(spec.points, dtype=np.int32)
        for block in sorted(self.done()):
            with np.load(self.blocks_dir / f'{block:06d}.npz') as data:
                where = slice(spec.block_range(block).start, spec.block_range(block).stop)
                for k in spec.outputs:
                    flat[k][where] = data[k]
                flat['run'][where] = int(data['run'])
        return {k: v.reshape(spec.shape) for k, v in flat.items()}

    def dataset(self):
        """The results as an ``xarray.Dataset`` (see module docstring)."""
        import xarray as xr
        spec = self.spec
        dims = ('y', 'x', 'sample')[: len(spec.shape)]
        coords = {'x': ('x', np.asarray(spec.x.values), {'key': spec.x.key}),
                  'y': ('y', np.asarray(spec.y.values if spec.y else [0.0]),
                        {'key': spec.y.key if spec.y else ''})}
        data = {k: (dims, v) for k, v in self.arrays().items()}
        for dist, draw in zip(spec.vary, spec.draws):
            data[f'draw:{dist.key}'] = ('sample', np.asarray(draw))
        ds = xr.Dataset(data, coords=coords, attrs={
            'title': f'drill_twin {spec.kind} sweep', 'kind': spec.kind,
            'x_key': spec.x.key, 'y_key': spec.y.key if spec.y else '',
            'spec': spec.to_json(), 'blocks_done': len(self.done()),
            'blocks': spec.blocks})
        if spec.samples:
            ds = _monte_carlo(ds, spec)
        return ds

    def write_dataset(self) -> Path:
        """``OUT/sweep.nc`` (netCDF 3 through scipy: no HDF5 library needed)."""
        ds = self.dataset()
        path = self.out / 'sweep.nc'
        tmp = path.with_suffix('.nc.tmp')
        ds.to_netcdf(tmp, engine='scipy')
        os.replace(tmp, path)
        return path


def _monte_carlo(ds, spec: SweepSpec):
    """Quantiles of every output over the samples, and the probability of stick-slip (the
    fraction of samples with a positive stick fraction) where it was computed."""
    for k in spec.outputs:
        values = ds[k].values.astype(float)
        for q in QUANTILES:
            ds[f'{k}_q{int(round(100 * q)):02d}'] = (('y', 'x'), _nanquantile(values, q))
    if 'stick_fraction' in spec.outputs:
        sf = ds['stick_fraction'].values
        counted = np.isfinite(sf).sum(axis=-1)
        stuck = (np.nan_to_num(sf, nan=0.0) > 0).sum(axis=-1)
        with np.errstate(invalid='ignore', divide='ignore'):
            ds['stick_slip_probability'] = (('y', 'x'), np.where(counted > 0, stuck / counted,
                                                                 np.nan))
    return ds


def _nanquantile(values, q):
    out = np.full(values.shape[:-1], np.nan)
    ok = np.isfinite(values).any(axis=-1)
    if ok.any():
        out[ok] = np.nanquantile(values[ok], q, axis=-1)
    return out


def _atomic_write(path: Path, data: bytes):
    tmp = path.with_suffix(path.suffix + '.tmp')
    tmp.write_bytes(data)
    os.replace(tmp, path)

"""Where a sweep keeps its results: a directory that survives a kill and a full disk.

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
that are not finished; a different spec is refused, and so is a ``spec.json`` that cannot
be read (it is never overwritten).  Finished blocks are a cache: a file of ``blocks/``
that does not load or does not match the spec is reported (:meth:`SweepStore.scan`) and
its block computed again.  A write that fails (a full disk, no permission) is one
:class:`~drill_twin.errors.ParameterError`; it leaves no temporary file and a
directory the same command resumes.
"""
from __future__ import annotations

import io
import json
import os
import re
import zipfile
from pathlib import Path

import numpy as np

from ..errors import ParameterError
from .spec import SweepSpec, load_json

__all__ = ['SweepStore', 'QUANTILES', 'stored_spec', 'read_stored', 'parse_stored',
           'holds_other_sweep', 'atomic_write', 'SPEC_FILE']

#: quantiles of a Monte Carlo sweep's statistics over the samples
QUANTILES = (0.05, 0.5, 0.95)
SPEC_FILE = 'spec.json'
#: largest spec.json read (a Monte Carlo spec holds its draws: ~35 MB at the limits)
MAX_SPEC_BYTES = 128 * 2 ** 20
#: the name of block number NNNNNN (6 digits: the blocks are fewer than 10^6)
_BLOCK_NAME = re.compile(r'^(\d{6})\.npz$')
#: what a directory may hold and still count as empty (a run that could not write its
#: spec.json left it)
_LEFTOVERS = {SPEC_FILE + '.tmp', 'blocks'}
_REMEDY = 'give another --out, or remove the directory to start again'


# --- spec.json --------------------------------------------------------------------------
def read_stored(out) -> tuple[SweepSpec, int] | None:
    """``(spec, runs)`` of ``out/spec.json``, None if there is none; one that cannot be
    read or is not a sweep's is a :class:`ParameterError` naming the file."""
    meta = Path(out) / SPEC_FILE
    if not (meta.exists() or meta.is_symlink()):
        return None
    try:
        if meta.stat().st_size > MAX_SPEC_BYTES:
            raise ParameterError(f'{meta}: larger than {MAX_SPEC_BYTES >> 20} MB: not a '
                                 f"sweep's spec.json; {_REMEDY}")
        data = meta.read_bytes()
    except OSError as exc:
        raise ParameterError(f'{meta}: cannot read ({exc.strerror or exc}); {_REMEDY}') \
            from None
    return parse_stored(data, meta)


def parse_stored(data: bytes, where) -> tuple[SweepSpec, int]:
    """``(spec, runs)`` of the bytes of a spec.json (``where`` names it in errors)."""
    try:
        stored = load_json(bytes(data).decode('utf-8'))
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise ParameterError(f"{where}: not a sweep's spec.json ({type(exc).__name__}: "
                             f'{" ".join(str(exc).split())[:80]}); {_REMEDY}') from None
    try:
        if not isinstance(stored, dict) or set(stored) != {'spec', 'runs'}:
            raise ParameterError('not a mapping of spec and runs')
        runs = stored['runs']
        if not isinstance(runs, int) or isinstance(runs, bool) or runs < 0:
            raise ParameterError(f'runs = {str(runs)[:40]!r} is not a count')
        return SweepSpec.from_dict(stored['spec']), runs
    except ParameterError as exc:
        raise ParameterError(f"{where}: not a sweep's spec.json: {exc}; {_REMEDY}") from None


def stored_spec(out) -> SweepSpec | None:
    """The spec kept in ``out/spec.json`` (None if ``out`` holds no sweep)."""
    stored = read_stored(out)
    return None if stored is None else stored[0]


def holds_other_sweep(out, spec: SweepSpec) -> bool:
    """Whether ``out`` holds a sweep other than ``spec``."""
    stored = stored_spec(out)
    return stored is not None and stored.to_json() != spec.to_json()


# --- writing ----------------------------------------------------------------------------
def atomic_write(path, data: bytes, hint: str = '') -> None:
    """``data`` to ``path`` through a temporary file, synced, then renamed: a kill or a
    failed write leaves the old file (or none) and no temporary one.  A write that fails
    is a :class:`ParameterError` (``hint`` appended)."""
    path = Path(path)
    tmp = path.with_name(path.name + '.tmp')
    try:
        with open(tmp, 'wb') as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        _remove(tmp)
        if isinstance(exc, OSError):
            raise ParameterError(f'{path}: cannot write ({exc.strerror or exc}){hint}') \
                from None
        raise


def _remove(path: Path) -> None:
    try:
        path.unlink(missing_ok=True)
    except OSError:
        pass     # (what could not be removed is reported by the write that failed)


class _BadBlock(Exception):
    """A file of ``blocks/`` that is not a finished block of this sweep (why)."""


class SweepStore:
    """The result directory of one sweep (see module docstring).  Reading
    (:meth:`scan`, :meth:`done`, :meth:`arrays`, :meth:`dataset`) changes nothing; a run
    that computes starts with :meth:`begin_run`."""

    def __init__(self, out, spec: SweepSpec):
        self.out = Path(out)
        self.spec = spec
        self.blocks_dir = self.out / 'blocks'
        if self.out.exists() and not self.out.is_dir():
            raise ParameterError(f'{self.out}: not a directory; {_REMEDY}')
        stored = read_stored(self.out)
        if stored is None:
            self.run = 0
            if not self._empty():
                raise ParameterError(f'{self.out} exists and is not a sweep directory (no '
                                     f'{SPEC_FILE}); {_REMEDY}')
        elif stored[0].to_json() != spec.to_json():
            raise ParameterError(f'{self.out} holds a different sweep (spec.json): give '
                                 'another --out, or remove it to start again')
        else:
            self.run = stored[1]

    def _empty(self) -> bool:
        try:
            entries = list(self.out.iterdir()) if self.out.exists() else []
            return all(p.name in _LEFTOVERS and not (p.is_dir() and any(p.iterdir()))
                       for p in entries)
        except OSError as exc:
            raise ParameterError(f'{self.out}: cannot read ({exc.strerror or exc})') from None

    def begin_run(self) -> int:
        """Count a new run (the number its blocks carry) and record the spec.  A failed
        write leaves the directory as it was (a new one removed again)."""
        created = not self.out.exists()
        try:
            self.out.mkdir(parents=True, exist_ok=True)
            atomic_write(self.out / SPEC_FILE, json.dumps(
                {'spec': json.loads(self.spec.to_json()), 'runs': self.run + 1}).encode())
            self.blocks_dir.mkdir(exist_ok=True)
        except (OSError, ParameterError) as exc:
            if created:
                _rmdir(self.blocks_dir, self.out)
            if isinstance(exc, OSError):
                raise ParameterError(f'{self.out}: cannot write ({exc.strerror or exc})') \
                    from None
            raise
        for stale in self.blocks_dir.glob('*.tmp'):   # of a write a kill interrupted
            _remove(stale)
        self.run += 1
        return self.run

    # --- blocks -----------------------------------------------------------------------
    def _path(self, block: int) -> Path:
        return self.blocks_dir / f'{block:06d}.npz'

    def save(self, result) -> None:
        """Store one block's result as it arrives."""
        block = int(result['block'])
        buffer = io.BytesIO()
        np.savez(buffer, run=np.int32(self.run), compute_s=float(result['compute_s']),
                 **{k: np.asarray(result[k]) for k in self.spec.outputs})
        atomic_write(self._path(block), buffer.getvalue(), hint='; the finished blocks are '
                     'kept: the same command resumes the sweep')

    def scan(self) -> tuple[set[int], list[str]]:
        """The finished blocks (files that load and match the spec), and one line for each
        other file of ``blocks/``: a bad block (computed again) or a stranger (ignored)."""
        done, problems = set(), []
        for path in self._files():
            block = self._block_of(path)
            if block is None:
                problems.append(f'{path}: not a block of this sweep ({self.spec.blocks} '
                                'blocks): ignored')
                continue
            try:
                self._read(path, block)
            except _BadBlock as exc:
                problems.append(f'{path}: {exc}: computing the block again')
                continue
            done.add(block)
        return done, problems

    def make_room(self, blocks) -> None:
        """Clear the names the files of ``blocks`` are to be written to: an empty directory
        there is removed; one with files is refused (a file is replaced by the write)."""
        for block in blocks:
            path = self._path(block)
            if path.is_dir() and not path.is_symlink():
                try:
                    path.rmdir()
                except OSError:
                    raise ParameterError(f'{path}: a directory where block {block} is to be '
                                         'written: remove it') from None

    def done(self) -> set[int]:
        """Blocks finished in this run or an earlier one (see :meth:`scan`)."""
        return self.scan()[0]

    def _files(self) -> list[Path]:
        try:
            return sorted(p for p in self.blocks_dir.iterdir() if not p.name.endswith('.tmp')) \
                if self.blocks_dir.is_dir() else []
        except OSError as exc:
            raise ParameterError(f'{self.blocks_dir}: cannot read ({exc.strerror or exc})') \
                from None

    def _block_of(self, path: Path) -> int | None:
        m = _BLOCK_NAME.match(path.name)
        return int(m.group(1)) if m and int(m.group(1)) < self.spec.blocks else None

    def _read(self, path: Path, block: int) -> dict:
        """The arrays of a block file, checked against the spec (:class:`_BadBlock`)."""
        n = len(self.spec.block_range(block))
        try:
            with zipfile.ZipFile(path) as zf:
                out = {k: _member(zf, k, (n,), 'iu' if k == 'unstable' else 'f')
                       for k in self.spec.outputs}
                run = int(_member(zf, 'run', (), 'iu'))
        except _BadBlock:
            raise
        except Exception as exc:    # a cache file: whatever is wrong with it, it is redone
            raise _BadBlock(f'does not load ({type(exc).__name__}: '
                            f'{" ".join(str(exc).split())[:80]})') from None
        if not 1 <= run <= self.run:
            raise _BadBlock(f'run {run}: the sweep has had {self.run} runs')
        out['run'] = run
        return out

    # --- results ----------------------------------------------------------------------
    def _assemble(self) -> tuple[dict, int]:
        spec = self.spec
        flat = {k: np.full(spec.points, -1 if k == 'unstable' else np.nan,
                           dtype=np.int32 if k == 'unstable' else float)
                for k in spec.outputs}
        flat['run'] = np.zeros(spec.points, dtype=np.int32)
        count = 0
        for path in self._files():
            block = self._block_of(path)
            try:
                data = self._read(path, block) if block is not None else None
            except _BadBlock:
                data = None     # (reported by scan when the run began)
            if data is None:
                continue
            where = slice(spec.block_range(block).start, spec.block_range(block).stop)
            for k, v in data.items():
                flat[k][where] = v
            count += 1
        return {k: v.reshape(spec.shape) for k, v in flat.items()}, count

    def arrays(self) -> dict:
        """Every output over the grid (NaN / -1 where not computed yet) and ``run``."""
        return self._assemble()[0]

    def dataset(self):
        """The results as an ``xarray.Dataset`` (see module docstring)."""
        import xarray as xr
        spec = self.spec
        arrays, count = self._assemble()
        dims = ('y', 'x', 'sample')[: len(spec.shape)]
        coords = {'x': ('x', np.asarray(spec.x.values), {'key': spec.x.key}),
                  'y': ('y', np.asarray(spec.y.values if spec.y else [0.0]),
                        {'key': spec.y.key if spec.y else ''})}
        data = {k: (dims, v) for k, v in arrays.items()}
        for dist, draw in zip(spec.vary, spec.draws):
            data[f'draw:{dist.key}'] = ('sample', np.asarray(draw))
        ds = xr.Dataset(data, coords=coords, attrs={
            'title': f'drill_twin {spec.kind} sweep', 'kind': spec.kind,
            'x_key': spec.x.key, 'y_key': spec.y.key if spec.y else '',
            'spec': spec.to_json(), 'blocks_done': count, 'blocks': spec.blocks})
        if spec.samples:
            ds = _monte_carlo(ds, spec)
        return ds

    def write_dataset(self) -> Path:
        """``OUT/sweep.nc`` (netCDF 3 through scipy: no HDF5 library needed).  Made in
        memory and written as bytes: no file lock of xarray's (with a Dask client about,
        that lock is a distributed one)."""
        path = self.out / 'sweep.nc'
        atomic_write(path, bytes(self.dataset().to_netcdf(engine='scipy')))
        return path


def _rmdir(*folders: Path) -> None:
    """Remove ``folders`` (in order) where empty."""
    for folder in folders:
        try:
            folder.rmdir()
        except OSError:
            pass     # not empty, or not there: left as it is


def _member(zf: zipfile.ZipFile, name: str, shape: tuple, kinds: str) -> np.ndarray:
    """Array ``name`` of an ``.npz`` archive, read only if its header has ``shape`` and a
    numeric dtype of ``kinds`` (no allocation a hostile header asks for)."""
    try:
        info = zf.getinfo(f'{name}.npy')
    except KeyError:
        raise _BadBlock(f'no array {name}') from None
    with zf.open(info) as f:
        version = np.lib.format.read_magic(f)
        if version not in ((1, 0), (2, 0)):
            raise _BadBlock(f'array {name}: .npy version {version}')
        read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                       else np.lib.format.read_array_header_2_0)
        found, _, dtype = read_header(f)
        if found != shape or dtype.kind not in kinds or dtype.itemsize > 8:
            raise _BadBlock(f'array {name} is {dtype} of shape {found}, not of shape {shape}')
        size = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
        data = f.read(size)
    if len(data) != size:
        raise _BadBlock(f'array {name} is truncated')
    return np.frombuffer(data, dtype=dtype).reshape(shape)


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

"""Parameter sweeps on Dask: linear stability charts, nonlinear stick-slip maps and Monte
Carlo over uncertain parameters (``drill-twin sweep``, docs/sweeps.md)."""
from .engine import INLINE, SweepReport, block_points_for, run_sweep
from .evaluate import evaluate_block
from .spec import Axis, Distribution, SweepSpec, parse_axis, parse_distribution
from .store import SweepStore

__all__ = ['SweepSpec', 'Axis', 'Distribution', 'parse_axis', 'parse_distribution',
           'run_sweep', 'SweepReport', 'block_points_for', 'evaluate_block', 'SweepStore',
           'INLINE']

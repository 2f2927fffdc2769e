"""ROS-free drill-string physics: parameters, bit/rock law, models, jitted kernel, simulation.

Importing the package points numba's on-disk cache at a directory keyed by a
hash of these sources (:mod:`drill_twin.physics.numba_cache`), so compiled
code can never be stale.
"""
from . import numba_cache as _numba_cache

_numba_cache.configure()

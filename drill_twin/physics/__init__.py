"""ROS-free drill-string physics, numerics only: parameters, bit/rock law, models, the
jitted kernel, simulation.  Nothing here imports another drill_twin package (only the
root's :mod:`drill_twin.errors`); configuration files, control, stability and I/O sit
above.

Importing the package points numba's on-disk cache at a directory keyed by a hash of
these sources (:mod:`drill_twin.physics.numba_cache`), so compiled code can never be
stale.
"""
from . import numba_cache as _numba_cache

_numba_cache.configure()

"""drill_twin: a digital twin of a deep drilling system (physics, stability, estimation,
I/O, ROS 2 nodes).

Importing the package before numpy keeps numpy's BLAS on one thread unless the user
chose otherwise: every matrix here is small (at most a few hundred rows), where a
thread pool only costs — measured on the 2-core target with a busy second core, a
117×117 product took 3.3 ms with two OpenBLAS threads and 0.09 ms with one.
"""
import os as _os

for _name in ('OPENBLAS_NUM_THREADS', 'OMP_NUM_THREADS', 'MKL_NUM_THREADS'):
    _os.environ.setdefault(_name, '1')

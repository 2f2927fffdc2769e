"""The compiler settings of the time-integration kernel, in one place.

Every function of the stepping path (right-hand side, RK4 stage, event location, the
interface law, the bottom-hole surface, the delayed-signal history) is compiled by
:func:`kernel_jit`: numba ``njit`` with the on-disk cache, ``nogil`` (the ROS node and
the sweep workers run the kernel beside other threads) and **without numba's reference
counting** (``_nrt=False``).

Why no reference counting: numba keeps a reference count on every array it passes or
takes from a tuple, an atomic increment and decrement per array per call.  The kernel's
functions take 10-30 arrays each and are called five times per step, so on a one-degree-of-
freedom model those atomic operations were two thirds of the step's time (measured with
``perf``: ``NRT_incref``/``NRT_decref`` under ``rhs``).  The stepping functions never
allocate, return or keep an array — they only read and write the arrays their caller
owns — so they need no counts: the arrays are borrowed for the duration of the call.
The functions that allocate (the scratch arrays of :func:`drill_twin.physics.kernel.advance`
and ``snapshot``) keep the runtime and own the arrays while the kernel runs.  A kernel
function that tried to allocate would not compile (numba refuses), so the rule is
enforced, not just documented.

What is inlined at numba's level (``inline='always'``): the small scalar helpers of the
interface law and the bottom surface, the named views of the scratch array (they return
array views, which without reference counting must not cross a call), and the right-hand
side at its one call site in the RK4 stage loop.  Numba inlines by re-typing the callee's
IR at every call site, so an inlined body costs its compile time once per site: with the
right-hand side inlined at three sites and the chain solves at twelve, compiling the
kernel took 250 s on 2 cores; with one site each, 65 s, at the same cost per step (paired
runs, docs/benchmarks.md) and bit-identical results.
"""
from __future__ import annotations

from numba import njit

__all__ = ['kernel_jit', 'entry_jit', 'COMPILED_FUNCTIONS']

#: names of the kernel's functions that numba compiles on their own (not inlined): what a
#: cold start compiles, for a progress count
COMPILED_FUNCTIONS: list = []


def entry_jit(func):
    """Decorate an entry point of the kernel (called from Python, allocates its scratch
    arrays, so it keeps numba's runtime): ``njit(cache=True, nogil=True)``."""
    COMPILED_FUNCTIONS.append(f'{func.__module__}.{func.__qualname__}')
    return njit(cache=True, nogil=True)(func)


def kernel_jit(func=None, *, inline: str = 'never'):
    """Decorate a stepping-path function: ``njit(cache=True, nogil=True, _nrt=False)``
    (``inline='always'`` for numba-level inlining of tiny helpers)."""
    jit = njit(cache=True, nogil=True, inline=inline, _nrt=False)

    def decorate(f):
        if inline == 'never':
            COMPILED_FUNCTIONS.append(f'{f.__module__}.{f.__qualname__}')
        return jit(f)
    return decorate if func is None else decorate(func)

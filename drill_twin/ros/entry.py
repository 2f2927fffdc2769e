"""Console-script entry points of the nodes (``ros2 run drill_twin twin_node`` ...).

This module imports nothing heavy: it first makes SIGINT and SIGTERM end the
process quietly (exit code 0, no traceback) while the node's modules are still
being imported, then imports and runs the node.  Once rclpy is initialised its
own handlers shut the node down (:func:`drill_twin.ros.common.run_node`).
"""
from __future__ import annotations

import importlib
import logging
import os
import signal
import sys
import threading
import time
from contextlib import contextmanager

__all__ = ['install_quiet_signals', 'rclpy_took_over', 'interruptible', 'twin_node',
           'soft_torque_node', 'top_drive_controller', 'mcap_recorder', 'downhole_estimator',
           'opcua_bridge']

_ROS_HANDLES_SIGNALS = [False]
_INTERRUPTIBLE = [False]
_NODE_PROCESS = [False]      # this process is a node's console script (``_run``)
#: once a signal has shut ROS down, a node process leaves within this time [s] even if
#: its teardown stalls (launch escalates SIGINT to SIGTERM after 5 s)
SHUTDOWN_GRACE_S = 5.0


def _quiet_exit(signum, frame):
    if not _ROS_HANDLES_SIGNALS[0] or _INTERRUPTIBLE[0]:
        raise SystemExit(0)
    # after rclpy.init its C-level handler has already shut the context down: spinning
    # ends by itself and the node is destroyed properly


def install_quiet_signals():
    """SIGINT/SIGTERM before rclpy is initialised: exit 0 without a traceback."""
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _quiet_exit)


def rclpy_took_over():
    """Called right after ``rclpy.init``: from now on a signal is a ROS shutdown.  In a
    node's own process, a guard thread then bounds the shutdown."""
    _ROS_HANDLES_SIGNALS[0] = True
    if _NODE_PROCESS[0]:
        threading.Thread(target=_leave_if_shutdown_stalls, name='shutdown_guard',
                         daemon=True).start()


def _leave_if_shutdown_stalls():
    """Wait until ROS is shut down (by a signal, or at the node's normal end), then give
    the teardown :data:`SHUTDOWN_GRACE_S`; a process still alive by then leaves with exit
    code 0.  A signalled node normally exits well within a second; twice in three full
    test runs one did not exit in 20 s (``rclpy.spin`` or the middleware's teardown after
    the signal; not reproduced in 88 runs alone), and a node that ignores the signal it
    was stopped with would be killed, losing what a kill loses."""
    import rclpy
    while rclpy.ok():
        time.sleep(0.1)
    if _INTERRUPTIBLE[0]:
        # a signal while the node loads or compiles its kernels (numba holds the
        # interpreter for up to a minute per function, so the Python-level handler would
        # run only after it): nothing is open yet, nothing to save — leave now.  numba
        # writes its cache files by rename, so an interrupted compile leaves none half-made
        os._exit(0)
    time.sleep(SHUTDOWN_GRACE_S)
    print(f'shutdown did not finish within {SHUTDOWN_GRACE_S:g} s of the signal: leaving',
          file=sys.stderr, flush=True)
    os._exit(0)


@contextmanager
def interruptible():
    """A long computation during construction (loading a configuration, compiling the
    kernels on a cold numba cache: a minute on a loaded machine) that a signal may cut
    short: SIGINT/SIGTERM inside end the process at once with exit code 0.  rclpy's
    handler, which chains to ours, has already shut the context down by then."""
    before, _INTERRUPTIBLE[0] = _INTERRUPTIBLE[0], True
    try:
        yield
    finally:
        _INTERRUPTIBLE[0] = before


def _run(module: str, function: str = 'main') -> int:
    """Run a node's ``main`` and leave at once: the node has closed its recording and shut
    ROS down, so the interpreter's own teardown (about half a second of module and JIT
    clean-up) is skipped, which keeps a signalled node's exit well under a second."""
    install_quiet_signals()
    _NODE_PROCESS[0] = True
    code = getattr(importlib.import_module(module), function)()
    logging.shutdown()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code if isinstance(code, int) else 0)


def twin_node() -> int:
    return _run('drill_twin.ros.twin_node')


def soft_torque_node() -> int:
    return _run('drill_twin.ros.soft_torque_node')


def top_drive_controller() -> int:
    return _run('drill_twin.ros.soft_torque_node', 'main_top_drive_controller')


def mcap_recorder() -> int:
    return _run('drill_twin.ros.recorder_node')


def downhole_estimator() -> int:
    return _run('drill_twin.ros.estimator_node')


def opcua_bridge() -> int:
    return _run('drill_twin.ros.opcua_bridge')

"""Helpers shared by the drill_twin nodes: parameters from the settings tables, and the
process life cycle (init, construct, spin, shut down) with clean exits."""
from __future__ import annotations

import difflib
import sys

import rclpy
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor
from rclpy._rclpy_pybind11 import RCLError
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

from ..errors import ParameterError
from ..runtime.settings import Setting, check
from .entry import install_quiet_signals, rclpy_took_over

__all__ = ['float_range', 'declare_settings', 'warn_unknown_overrides', 'run_node', 'say',
           'answer_every_transition']


def float_range(lo, hi, text) -> ParameterDescriptor:
    """Descriptor of a float parameter with a closed range."""
    return ParameterDescriptor(description=text, floating_point_range=[
        FloatingPointRange(from_value=float(lo), to_value=float(hi), step=0.0)])


def _descriptor(setting: Setting) -> ParameterDescriptor:
    if setting.low is not None:
        desc = float_range(setting.low, setting.high, setting.text)
    else:
        desc = ParameterDescriptor(description=setting.text)
    desc.read_only = setting.read_only
    return desc


_TYPE_NAMES = {bool: 'true or false', float: 'a number', int: 'an integer', str: 'a string',
               list: 'a list of strings'}


def declare_settings(node, settings):
    """Declare one ROS parameter per :class:`~drill_twin.runtime.settings.Setting`
    (read-only ones act at start-up only: ``ros2 param describe`` says so).

    A start-up value (``-p name:=value``) of the wrong type or out of range raises
    :class:`~drill_twin.errors.ParameterError` with one line naming the
    parameter, the value, its unit and what is allowed.
    """
    for s in settings:
        try:
            node.declare_parameter(s.name, s.default, _descriptor(s))
        except ParameterException:
            given = getattr(node, '_parameter_overrides', {}).get(s.name)
            value = given.value if given is not None else s.default
            reason = check(s, value) if isinstance(value, type(s.default)) or (
                isinstance(s.default, float) and isinstance(value, int)) else None
            if reason is None:
                reason = (f'{s.name} = {value!r}: must be {_TYPE_NAMES[type(s.default)]}'
                          f' ({s.text})')
            raise ParameterError(f'parameter {reason}') from None


def warn_unknown_overrides(node):
    """Log the parameter overrides given to this node that it does not have (a typo such as
    ``real_time_facter`` would otherwise be ignored silently)."""
    for name in sorted(getattr(node, '_parameter_overrides', {})):
        if node.has_parameter(name):
            continue
        close = difflib.get_close_matches(name, list(node._parameters), n=1)
        hint = f' (did you mean {close[0]}?)' if close else ''
        node.get_logger().warning(f'unknown parameter {name!r} ignored{hint}')


def answer_every_transition(node):
    """Make a lifecycle node answer every ``~/change_state`` request with a result.

    rclpy's handler triggers the requested transition by id; one that does not start from
    the current state (``ros2 lifecycle set`` of ``configure`` while active, a mistyped
    id) raises inside the service callback, and the exception ends the process — a
    wrong call took the rig's twin down.  The guard answers ``success: false`` with one
    logged line naming the state and the transitions available there, and leaves the
    node as it was; valid requests go to rclpy's handler unchanged."""
    service = node._service_change_state
    handler = service.callback

    def guarded(request, response):
        machine = node._state_machine
        state_id, state = machine.current_state
        available = {t[0]: t[1] for t in machine.available_transitions}
        wanted = request.transition.id
        if request.transition.label:
            label = request.transition.label
            wanted = next((i for i, name in available.items() if name == label), None)
        if wanted not in available:
            asked = request.transition.label or request.transition.id
            node.get_logger().warning(
                f'lifecycle transition {asked!r} refused: not available in state {state} '
                f'(available: {", ".join(f"{n} ({i})" for i, n in available.items())})')
            response.success = False
            return response
        try:
            return handler(request, response)
        except RCLError as exc:          # the state changed between the check and here
            node.get_logger().warning(f'lifecycle transition {wanted} refused: {exc}')
            response.success = False
            return response
    service.callback = guarded


def say(node, text: str):
    """Log ``text`` as the node, or — when a signal has already shut the node's context
    down (its /rosout publisher is gone) — print it to stderr in the log's format; rclpy
    would otherwise report 'Failed to publish log message to rosout'."""
    if node.context.ok():
        node.get_logger().info(text)
    else:
        print(f'[INFO] [{node.get_name()}]: {text}', file=sys.stderr, flush=True)


def _one_line(exc) -> str:
    return ' '.join(str(exc).split())


def run_node(node_class, label, args=None) -> int:
    """init, construct, spin, shut down.

    Exit codes: 0 after SIGINT/SIGTERM (also when the signal arrives during
    construction); 2 with one line on stderr for bad configuration or parameters;
    an unexpected internal error keeps its traceback (exit code 1).
    """
    import threading
    if threading.current_thread() is threading.main_thread():
        install_quiet_signals()   # rclpy chains its handlers to these
    try:
        rclpy.init(args=args)
    except RCLError as exc:      # ROS could not parse the command line's --ros-args
        print(f'{label}: error: the ROS arguments do not parse ({_one_line(exc)}); note '
              "that an empty value such as -p record_path:='' reaches ROS as nothing: write "
              "-p record_path:=none", file=sys.stderr)
        return 2
    rclpy_took_over()
    node = None
    try:
        node = node_class()
    except (ParameterError, ParameterException, ValueError, OSError) as exc:
        if not rclpy.ok():      # a signal shut the context down while we were building
            return 0
        print(f'{label}: error: {_one_line(exc)}', file=sys.stderr)
        rclpy.try_shutdown()
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        rclpy.try_shutdown()
        return 0
    except Exception:
        if not rclpy.ok():
            return 0
        raise
    executor = None
    try:
        executor = _SignalSafeExecutor()
        rclpy.spin(node, executor=executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:  # noqa: BLE001
        # SIGINT/SIGTERM shut the context down from the signal handler; a callback that
        # was running at that moment fails to publish. That is the shutdown, not an error.
        if rclpy.ok():
            raise
    finally:
        if executor is not None:
            executor.shutdown(timeout_sec=0.5)
        node.destroy_node()
        rclpy.try_shutdown()
        _leave_the_graph()
    return 0


class _SignalSafeExecutor(SingleThreadedExecutor):
    """rclpy's single-threaded executor, safe to collect half-built: a signal that shuts
    the context down while ``__init__`` runs leaves the instance without ``_sigint_gc``, and
    rclpy's ``__del__`` then printed an AttributeError traceback on a clean exit (seen once
    in a full suite run, SIGTERM right after the OPC UA bridge began to listen)."""

    _sigint_gc = None


def _leave_the_graph():
    """Finalise the default context: its DDS participant is deleted and announces that it
    leaves, so ``ros2 node list`` drops the node at once.  Without this the process left by
    ``os._exit`` (:func:`drill_twin.ros.entry._run`) before the participant was deleted,
    and discovery kept the node listed until its lease ran out (25-45 s)."""
    try:
        rclpy.utilities.get_default_context().destroy()
    except Exception:  # noqa: BLE001 - already destroyed, or never initialised
        pass

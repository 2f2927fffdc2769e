"""Helpers shared by the drill_twin nodes."""
from __future__ import annotations

import rclpy
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor

from ..physics.parameters import ParameterError

__all__ = ['float_range', 'run_node']


def float_range(lo, hi, text) -> ParameterDescriptor:
    """Descriptor of a float parameter with a closed range."""
    return ParameterDescriptor(description=text, floating_point_range=[
        FloatingPointRange(from_value=float(lo), to_value=float(hi), step=0.0)])


def run_node(node_class, label, args=None) -> int:
    """init, construct (configuration errors: message, exit 2), spin, clean shutdown."""
    rclpy.init(args=args)
    try:
        node = node_class()
    except (ParameterError, ValueError, OSError) as exc:
        print(f'{label}: error: {exc}')
        rclpy.shutdown()
        return 2
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
        pass
    except Exception:  # noqa: BLE001
        # SIGINT/SIGTERM shut the context down from the signal handler; a callback that
        # was running at that moment fails to publish. That is the shutdown, not an error.
        if rclpy.ok():
            raise
    finally:
        node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0

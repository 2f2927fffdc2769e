"""``mcap_recorder``: record the drill_twin topics of a ROS graph to one MCAP file.

Subscribes (raw CDR, no decode/encode) to every topic a drill_twin node publishes or
reads (:data:`drill_twin.topics.RECORDABLE`: set-points, controller commands, bit and
surface measurements, stability advisories, the downhole estimator's estimates,
``/diagnostics``, ``/clock``, ``/parameter_events``) with the QoS their publishers
offer, and writes a rosbag2-profile MCAP file
(:class:`drill_twin.io.mcap_writer.McapRecorder`).  Log time is this node's
ROS time: run it with ``use_sim_time`` when the twin publishes ``/clock``.
A chunk holds at most ``chunk_period_s``: SIGKILL loses at most that much;
SIGINT/SIGTERM close the file properly.

For an exactly reproducible recording of one twin (resimulation), use the
twin's own ``record_path`` parameter instead: it records set-points at the
simulated time the twin applied them, which an outside observer cannot know.
"""
from __future__ import annotations

import datetime
import json
import os

from rclpy.node import Node

from .. import topics as T
from ..errors import ParameterError
from ..io.mcap_reader import RUN_METADATA
from ..io.mcap_writer import McapRecorder
from ..io.run_recorder import package_version, run_metadata
from ..runtime.settings import RECORDER_SETTINGS, ros_home
from .common import declare_settings, run_node, say, warn_unknown_overrides
from .messages import available, message_class, qos_profile

__all__ = ['RecorderNode', 'main']


class RecorderNode(Node):
    """The recorder node (see module docstring)."""

    def __init__(self, **kwargs):
        super().__init__('mcap_recorder', **kwargs)
        declare_settings(self, RECORDER_SETTINGS)
        warn_unknown_overrides(self)
        stamp = datetime.datetime.now(datetime.UTC).strftime('%Y%m%d_%H%M%S')
        path = self.get_parameter('path').value or os.path.join(
            ros_home(), 'drill_twin', f'mcap_recorder_{stamp}.mcap')
        g = self.get_parameter
        wanted = [t for t in g('topics').value if t]
        wanted = [w.lstrip('/') if w.lstrip('/') in T.RECORDABLE_BY_NAME else w
                  for w in wanted]
        unknown = set(wanted) - set(T.RECORDABLE_BY_NAME)
        if unknown:
            raise ParameterError(f'not drill_twin topics: {sorted(unknown)}; known: '
                                 f'{", ".join(T.RECORDABLE_BY_NAME)}')
        self.writer = McapRecorder(path, chunk_period_s=g('chunk_period_s').value,
                                   library=f'drill_twin {package_version()} mcap_recorder')
        self.writer.add_metadata(RUN_METADATA, run_metadata(
            'ros_time', self.get_namespace(), topics=json.dumps(wanted or 'all'),
            use_sim_time=str(g('use_sim_time').value).lower()))
        for topic in T.RECORDABLE:
            if wanted and topic.name not in wanted:
                continue
            if not available(topic.type):   # e.g. tf2_msgs, absent from the PyPI wheels
                self.get_logger().info(f'not recording {topic.name}: {topic.type} is not '
                                       'installed')
                continue
            name = self.resolve_topic_name(topic.name)
            self.create_subscription(
                message_class(topic.type), topic.name,
                lambda data, n=name, t=topic: self._record(n, t, data),
                qos_profile(topic.qos), raw=True)
        self.create_timer(g('chunk_period_s').value, self.writer.flush)
        self.get_logger().info(f'recording {len(wanted) or len(T.RECORDABLE)} topics to '
                               f'{self.writer.path}')

    def _record(self, name, topic, data: bytes):
        self.writer.write(name, topic.type, topic.qos, data, self.get_clock().now().nanoseconds)

    def destroy_node(self):
        self.writer.close()
        say(self, f'{self.writer.messages_written} messages in {self.writer.path}')
        return super().destroy_node()


def main(args=None):
    return run_node(RecorderNode, 'mcap_recorder', args)


if __name__ == '__main__':
    raise SystemExit(main())

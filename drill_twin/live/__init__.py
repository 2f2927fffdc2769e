"""The live view: the twin served over the Foxglove WebSocket protocol (no rclpy here).

:class:`~drill_twin.live.server.LiveView` advertises the twin's topics with their ROS 2
schemas (``ros2msg``, CDR) and hands each message to the ``foxglove-sdk`` server without
blocking; :func:`~drill_twin.live.run.serve_paced` drives an offline run in real time for
``drill-twin simulate --live`` and ``drill-twin scenario run --live``.
"""

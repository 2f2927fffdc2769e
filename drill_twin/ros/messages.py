"""ROS message and QoS objects from the plain-data interface of :mod:`drill_twin.topics`."""
from __future__ import annotations

import importlib

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..topics import QoS

__all__ = ['message_class', 'to_message', 'qos_profile', 'available']


def message_class(type_name: str):
    """The Python class of ``pkg/msg/Type`` (or ``pkg/Type``)."""
    parts = type_name.split('/')
    module = importlib.import_module(f'{parts[0]}.msg')
    return getattr(module, parts[-1])


def available(type_name: str) -> bool:
    """True when the Python message package of ``pkg/msg/Type`` is installed (the PyPI ROS
    wheels have no ``tf2_msgs``: the twin then records and serves ``/tf`` but does not
    publish it over DDS)."""
    try:
        message_class(type_name)
    except (ImportError, AttributeError):
        return False
    return True


def to_message(cls, fields: dict):
    """An instance of ``cls`` with the nested ``fields`` set (others keep defaults)."""
    msg = cls()
    types = cls.get_fields_and_field_types()
    for key, value in fields.items():
        kind = types[key]
        if isinstance(value, dict):
            setattr(msg, key, to_message(type(getattr(msg, key)), value))
        elif isinstance(value, list) and kind.startswith('sequence<') and '/' in kind:
            elem = message_class(kind[len('sequence<'):].rstrip('>').split(',')[0])
            setattr(msg, key, [to_message(elem, v) for v in value])
        elif kind in ('byte', 'octet'):
            setattr(msg, key, bytes([int(value)]))
        else:
            setattr(msg, key, value)
    return msg


def qos_profile(qos: QoS) -> QoSProfile:
    """rclpy profile of a :class:`drill_twin.topics.QoS`."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=qos.depth,
                      reliability=ReliabilityPolicy[qos.reliability.upper()],
                      durability=DurabilityPolicy[qos.durability.upper()])

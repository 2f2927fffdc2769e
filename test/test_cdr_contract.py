"""Contract of the pinned ``mcap-ros2-support`` dynamic serialiser (io/cdr.py): for every
message type drill_twin records, what it encodes rclpy decodes to the same values, and
what rclpy encodes it decodes to the same values (values, not bytes: CDR padding is not
deterministic)."""
import math

import pytest

rclpy = pytest.importorskip('rclpy')
import importlib  # noqa: E402

from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402

from drill_twin.io.cdr import decoder_for, encoder_for  # noqa: E402
from drill_twin.io.msg_definitions import schema_text  # noqa: E402
from drill_twin.topics import ESTIMATE_TOPICS, TOPICS  # noqa: E402

TYPES = sorted({t.type for t in TOPICS + ESTIMATE_TOPICS})


def _installed(type_name) -> bool:
    """rclpy can serialise it (the PyPI ROS wheels have no tf2_msgs: /tf is written by
    the dynamic serialiser only, its schema from drill_twin/data/ros)."""
    try:
        get_message(type_name)
    except ImportError:
        return False
    return True


def get_message(type_name):
    pkg, _, name = type_name.split('/')
    return getattr(importlib.import_module(f'{pkg}.msg'), name)


def _sample(cls):
    """A message of ``cls`` with every numeric leaf set to a distinct value."""
    msg = cls()
    counter = [0]

    def fill(m):
        for name, kind in m.get_fields_and_field_types().items():
            value = getattr(m, name)
            counter[0] += 1
            if kind in ('double', 'float'):
                setattr(m, name, 1.25 * counter[0])
            elif kind.startswith(('int', 'uint')):
                setattr(m, name, counter[0] % 100)
            elif kind == 'boolean':
                setattr(m, name, counter[0] % 2 == 1)
            elif kind == 'string':
                setattr(m, name, f's{counter[0]}')
            elif kind.startswith('double[') and hasattr(value, '__len__'):
                for i in range(len(value)):
                    value[i] = 0.5 * (counter[0] + i)
            elif hasattr(value, 'get_fields_and_field_types'):
                fill(value)
    fill(msg)
    return msg


def _same(a, b):
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) or hasattr(a, 'tolist'):
        a, b = list(a), list(b)
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, float):
        return math.isclose(a, b, rel_tol=0, abs_tol=0) or a == b
    return a == b


def _plain(obj):
    """A decoded mcap_ros2 object as nested dicts and lists."""
    if isinstance(obj, (list, tuple)):
        return [_plain(x) for x in obj]
    names = getattr(obj, '__slots__', None)
    if names is None and hasattr(obj, '__dict__'):
        names = [n for n in vars(obj) if not n.startswith('_')]
    if names:
        return {n: _plain(getattr(obj, n)) for n in names}
    return obj


@pytest.mark.parametrize('type_name', [t if _installed(t) else pytest.param(
    t, marks=pytest.mark.skip(reason=f'{t}: message package not installed')) for t in TYPES])
def test_pinned_serialiser_agrees_with_rclpy(type_name):
    cls = get_message(type_name)
    msg = _sample(cls)
    expected = _plain_from_rclpy(msg)
    text = schema_text(type_name)
    ours = encoder_for(type_name, text)(expected)
    assert _same(_plain_from_rclpy(deserialize_message(ours, cls)), expected)
    decoded = _plain(decoder_for(type_name, text)(serialize_message(msg)))
    assert _same({k: decoded[k] for k in expected}, expected)


def _plain_from_rclpy(msg):
    out = {}
    for name in msg.get_fields_and_field_types():
        value = getattr(msg, name)
        if hasattr(value, 'get_fields_and_field_types'):
            out[name] = _plain_from_rclpy(value)
        elif isinstance(value, (list, tuple)) and value and \
                hasattr(value[0], 'get_fields_and_field_types'):
            out[name] = [_plain_from_rclpy(v) for v in value]
        elif hasattr(value, 'tolist'):
            out[name] = value.tolist()
        else:
            out[name] = value
    return out

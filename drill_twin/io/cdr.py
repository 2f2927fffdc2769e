"""CDR encoding and decoding of ROS 2 messages from their ``ros2msg`` definition text (no
ROS runtime needed): the one place that talks to the CDR library.

Decoding uses ``mcap_ros2.decoder.DecoderFactory`` (public API).  Encoding uses
``mcap_ros2``'s dynamic serialiser, which that package does not export publicly:
``requirements/base.txt`` (hence ``install_requires``) pins ``mcap-ros2-support`` to the
exact version whose behaviour ``test/test_cdr_contract.py`` checks (every message type
drill_twin writes, in both directions against rclpy's own serialisation, compared on the
decoded values: CDR padding bytes are not deterministic).
"""
from __future__ import annotations

from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory

__all__ = ['encoder_for', 'decoder_for']


def encoder_for(type_name: str, schema_text: str):
    """A function: message fields (nested dict, or an object with the field attributes)
    -> CDR bytes, for ``pkg/msg/Type`` with the full definition ``schema_text``."""
    from mcap_ros2._dynamic import serialize_dynamic  # pinned: see the module docstring
    return serialize_dynamic(type_name, schema_text)[type_name]


def decoder_for(type_name: str, schema_text: str):
    """A function: CDR bytes -> message object (attribute access to the fields)."""
    schema = Schema(id=1, name=type_name, encoding='ros2msg', data=schema_text.encode())
    decoder = DecoderFactory().decoder_for('cdr', schema)
    if decoder is None:
        raise ValueError(f'no CDR decoder for {type_name}')
    return decoder

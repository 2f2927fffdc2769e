"""rosbag2 schema text of a ROS 2 message type, built from the installed ``.msg`` files.

rosbag2 (``ros2msg`` schema encoding) stores the root definition first and
every nested type after it, each preceded by a line of 80 ``=`` and
``MSG: pkg/Type``; each type appears once, in depth-first order of first use
(what ``rosbag2_cpp`` and Foxglove expect).  The ``.msg`` files are looked up in
the ``share/<pkg>/msg`` directory of every prefix on ``AMENT_PREFIX_PATH``, then
in the running interpreter's prefix (where the PyPI ROS wheels put them).
"""
from __future__ import annotations

import functools
import os
import re
import sys
from pathlib import Path

__all__ = ['schema_text', 'find_msg_file', 'MessageDefinitionError', 'normalize_type']

_PRIMITIVES = {'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16',
               'uint16', 'int32', 'uint32', 'int64', 'uint64', 'string', 'wstring'}
_SEPARATOR = '=' * 80


class MessageDefinitionError(LookupError):
    """A message definition could not be found or parsed."""


def normalize_type(type_name: str) -> tuple[str, str]:
    """``pkg/msg/Type`` or ``pkg/Type`` -> ``(pkg, Type)``."""
    parts = type_name.split('/')
    if len(parts) == 3 and parts[1] == 'msg':
        return parts[0], parts[2]
    if len(parts) == 2:
        return parts[0], parts[1]
    raise MessageDefinitionError(f'not a message type name: {type_name!r}')


def _prefixes():
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if prefix:
            yield Path(prefix)
    yield Path(sys.prefix)


def find_msg_file(type_name: str) -> Path:
    """Path of the installed ``.msg`` file of ``pkg/msg/Type``."""
    pkg, name = normalize_type(type_name)
    for prefix in _prefixes():
        path = prefix / 'share' / pkg / 'msg' / f'{name}.msg'
        if path.is_file():
            return path
    raise MessageDefinitionError(
        f'{pkg}/msg/{name}.msg not found under AMENT_PREFIX_PATH or {sys.prefix}/share '
        '(install the ROS message packages: requirements/ros.txt, or source a ROS 2 setup)')


def _field_types(pkg: str, text: str):
    """Nested (non-primitive) types used by a definition, in order, as ``pkg/Type``."""
    for line in text.splitlines():
        line = line.split('#', 1)[0].strip()
        if not line:
            continue
        tokens = line.split()
        if len(tokens) < 2 or '=' in tokens[1] or tokens[2:3] and tokens[2].startswith('='):
            continue  # a constant (TYPE NAME=VALUE) or malformed
        base = re.sub(r'\[.*?\]$', '', tokens[0]).split('<=')[0]
        if base in _PRIMITIVES:
            continue
        yield base if '/' in base else f'{pkg}/{base}'


@functools.cache
def schema_text(type_name: str) -> str:
    """Full rosbag2 ``ros2msg`` definition of ``pkg/msg/Type`` (root first, then each
    dependency once after a separator line)."""
    root_pkg, root_name = normalize_type(type_name)
    blocks, seen = [], {f'{root_pkg}/{root_name}'}

    def visit(pkg_type):
        pkg, _ = normalize_type(pkg_type)
        text = find_msg_file(pkg_type).read_text()
        blocks.append((pkg_type, text))
        for dep in _field_types(pkg, text):
            dep_pkg, dep_name = normalize_type(dep)
            key = f'{dep_pkg}/{dep_name}'
            if key not in seen:
                seen.add(key)
                visit(key)

    visit(f'{root_pkg}/{root_name}')
    out = blocks[0][1].rstrip('\n') + '\n'
    for name, text in blocks[1:]:
        out += f'{_SEPARATOR}\nMSG: {name}\n{text.rstrip(chr(10))}\n'
    return out

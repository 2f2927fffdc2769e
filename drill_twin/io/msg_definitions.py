"""rosbag2 schema text and type hash of a ROS 2 message type, from the installed files.

Schema text: exactly what rosbag2 Jazzy writes (``rosbag2_cpp``'s
``LocalMessageDefinitionSource::get_full_text``): the root ``.msg`` file verbatim, then
for each dependency not written yet — dependencies of a definition in *alphabetical*
order of their ``pkg/Type`` name (a ``std::set``), depth first — a newline, a line of 80
``=``, ``MSG: pkg/Type`` and that file verbatim.  Dependencies are the field types found
by rosbag2's own pattern (first token of a line, primitives excepted; a bare ``Type`` is
in the definition's package).  Type hash: the ``RIHS01_...`` string of the type in its
installed ``.json`` type description (what Jazzy's rosbag2 stores as
``topic_type_hash``).  Files are looked up in the ``share/<pkg>/msg`` directory of every
prefix on ``AMENT_PREFIX_PATH``, then in the running interpreter's prefix (where the PyPI
ROS wheels put them), last in ``drill_twin/data/ros`` (``tf2_msgs/msg/TFMessage``, which
the PyPI wheels lack).
"""
from __future__ import annotations

import functools
import json
import os
import re
import sys
from pathlib import Path

__all__ = ['schema_text', 'type_hash', 'find_msg_file', 'MessageDefinitionError',
           'normalize_type']

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
    yield Path(__file__).resolve().parents[1] / 'data' / 'ros'


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


#: rosbag2's MSG_FIELD_TYPE_REGEX and PRIMITIVE_TYPES (local_message_definition_source.cpp)
_FIELD_TYPE = re.compile(r'(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+')
_ROSBAG2_PRIMITIVES = {'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16',
                       'uint16', 'int32', 'uint32', 'int64', 'uint64', 'string'}


def _dependencies(pkg: str, text: str) -> list[str]:
    """Field types of a definition as rosbag2 finds them, sorted (``pkg/Type``)."""
    deps = set()
    for match in _FIELD_TYPE.finditer(text):
        name = match.group(1)
        if name in _ROSBAG2_PRIMITIVES:
            continue
        deps.add(name if '/' in name else f'{pkg}/{name}')
    return sorted(deps)


@functools.cache
def schema_text(type_name: str) -> str:
    """Full rosbag2 ``ros2msg`` definition of ``pkg/msg/Type`` (module docstring)."""
    seen = set()

    def full_text(pkg_type):
        pkg, _ = normalize_type(pkg_type)
        text = find_msg_file(pkg_type).read_text()
        out = text
        for dep in _dependencies(pkg, text):
            if dep not in seen:
                seen.add(dep)
                out += f'\n{_SEPARATOR}\nMSG: {dep}\n' + full_text(dep)
        return out

    pkg, name = normalize_type(type_name)
    return full_text(f'{pkg}/{name}')


@functools.cache
def type_hash(type_name: str) -> str:
    """``RIHS01_...`` hash of ``pkg/msg/Type`` from its installed ``.json`` description."""
    pkg, name = normalize_type(type_name)
    path = find_msg_file(f'{pkg}/{name}').with_suffix('.json')
    try:
        hashes = json.loads(path.read_text())['type_hashes']
    except (OSError, ValueError, KeyError) as exc:
        raise MessageDefinitionError(f'no type description for {pkg}/msg/{name} at {path}: '
                                     f'{exc}') from None
    full = f'{pkg}/msg/{name}'
    for entry in hashes:
        if entry.get('type_name') == full:
            return entry['hash_string']
    raise MessageDefinitionError(f'{path} has no hash for {full}')

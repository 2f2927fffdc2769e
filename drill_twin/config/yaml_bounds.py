"""YAML read with bounds: size, nesting depth, node count with aliases expanded, integer
digits.  A configuration, a scenario and a ``--set`` value go through :func:`parse_yaml`;
every problem is one line naming the file (or ``--set``), the line and column and the
bound (docs/configuration.md)."""
from __future__ import annotations

from pathlib import Path

import yaml

from ..errors import ConfigError

__all__ = ['read_yaml', 'read_text', 'parse_yaml', 'check_yaml_bounds', 'BoundedLoader',
           'YamlLimitError', 'MAX_YAML_BYTES', 'MAX_YAML_DEPTH', 'MAX_YAML_NODES',
           'MAX_INT_DIGITS', 'shown']

def _yaml_problem(exc) -> str:
    """``line L, column C: problem (context)`` of a PyYAML error, at most 200
    characters."""
    mark = getattr(exc, 'problem_mark', None)
    problem = getattr(exc, 'problem', None) or str(exc).splitlines()[0]
    context = getattr(exc, 'context', None)
    if context:
        problem = f'{problem} ({context})'
    where = f'line {mark.line + 1}, column {mark.column + 1}: ' if mark is not None else ''
    return shown(' '.join(f'{where}{problem}'.split()), 200)


# --- bounded YAML ---------------------------------------------------------------------
#: largest configuration or scenario file (and ``--set`` value) read [bytes].  The shipped
#: files are at most 2.6 kB; a string of 1,000 sections written out is ~200 kB.  Text and
#: comments parse at ~30 MB/s (libyaml), so the bound is about memory and what the text
#: can hold, not time.
MAX_YAML_BYTES = 1 << 20
#: deepest nesting of collections.  The deepest value of a configuration is 4 levels down
#: (drill_string.sections[i].name), of a scenario 4 (steps[i].rotate.rpm); 32 leaves
#: room for any layout, and whatever reads the result recursively (the pure-Python
#: composer: 4 frames per level, copy.deepcopy: 3, json, repr) stays far below Python's
#: 1,000 frames.  The depth is checked on the parser's events, before any composer runs:
#: PyYAML's raises RecursionError at ~250 levels, libyaml's recurses in C (10^5 levels,
#: a 200 kB file, end the process with a segmentation fault).
MAX_YAML_DEPTH = 32
#: most nodes (scalars, sequences, mappings, keys) a document may hold once its aliases
#: are expanded.  A configuration of 1,000 string sections (17 nodes each) or a scenario
#: of 4,000 steps (4-5 nodes each) fits, and composing 20,000 nodes takes ~0.3 s here.
#: Whatever walks the result (validation, deepcopy, repr, json) walks the expanded tree:
#: the budget is what stops a "billion laughs" (nine aliases of nine: 9^9 nodes).
MAX_YAML_NODES = 20_000
#: most digits of an integer.  No key takes a number above 1e13 (the moduli [Pa]); int64
#: holds 19 digits, and every integer up to 19 digits converts to a float (what the
#: schema compares) without overflow.  Larger numbers are written as floats (1e25).
MAX_INT_DIGITS = 19
#: longest text of an integer scalar converted at all (signs, underscores, a 0b prefix:
#: 64 binary digits are below 20 decimal ones); longer is refused unread
_MAX_INT_TEXT = 80
#: what PyYAML's scalar constructors raise on text their tag does not fit
#: (``!!int abc``, ``!!timestamp 2001-02-30``, ``!!bool maybe``, a 400-digit sexagesimal)
_CONSTRUCT_ERRORS = (ValueError, TypeError, KeyError, AttributeError, IndexError,
                     OverflowError)


class YamlLimitError(yaml.YAMLError):
    """A document beyond a bound of :func:`parse_yaml` (one line, with the place)."""

    def __init__(self, problem: str, mark=None):
        super().__init__(problem)
        self.problem, self.problem_mark = problem, mark


#: libyaml's parser and composer when PyYAML was built with it (5-20x faster than the
#: pure-Python ones); the constructor is PyYAML's safe one either way
_FAST = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)


class _Frame:
    """An open collection of the event scan: its anchor, the node count when it opened,
    the deepest level reached inside it."""

    __slots__ = ('anchor', 'start', 'reach')

    def __init__(self, anchor, start, reach):
        self.anchor, self.start, self.reach = anchor, start, reach


def check_yaml_bounds(text: str, loader=_FAST):
    """Scan the events of ``text`` (the parser is a state machine: no recursion) and raise
    :class:`YamlLimitError` at the first bound exceeded: more than :data:`MAX_YAML_NODES`
    nodes with the aliases expanded, collections nested deeper than
    :data:`MAX_YAML_DEPTH` levels (aliases expanded), or an alias inside the node it
    names.  A malformed document raises PyYAML's own error."""
    frames: list[_Frame] = []
    sizes: dict = {}            # anchor -> (nodes, height) of a node composed whole
    nodes = 0

    def grow(count, reach, mark, alias=False):
        nonlocal nodes
        nodes += count
        if frames:
            frames[-1].reach = max(frames[-1].reach, reach)
        expanded = ' with its aliases expanded' if alias else ''
        if nodes > MAX_YAML_NODES:
            raise YamlLimitError(f'more than {MAX_YAML_NODES} YAML nodes{expanded} (a '
                                 'configuration or scenario has far fewer)', mark)
        if reach > MAX_YAML_DEPTH:
            raise YamlLimitError(f'YAML nested deeper than {MAX_YAML_DEPTH} levels'
                                 f'{expanded}', mark)

    for event in yaml.parse(text, Loader=loader):
        depth = len(frames)
        if isinstance(event, yaml.DocumentStartEvent):
            sizes.clear()
        elif isinstance(event, yaml.AliasEvent):
            if event.anchor in sizes:
                count, height = sizes[event.anchor]
                grow(count, depth + height, event.start_mark, alias=True)
            elif any(f.anchor == event.anchor for f in frames):
                raise YamlLimitError(f'alias *{event.anchor} inside the node it names (a '
                                     'recursive structure)', event.start_mark)
            else:
                raise YamlLimitError(f'alias *{event.anchor} names no anchor '
                                     f'&{event.anchor} before it', event.start_mark)
        elif isinstance(event, yaml.ScalarEvent):
            grow(1, depth + 1, event.start_mark)
            if event.anchor is not None:
                sizes[event.anchor] = (1, 1)
        elif isinstance(event, (yaml.SequenceStartEvent, yaml.MappingStartEvent)):
            grow(1, depth + 1, event.start_mark)
            frames.append(_Frame(event.anchor, nodes - 1, depth + 1))
        elif isinstance(event, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
            frame = frames.pop()
            if frame.anchor is not None:
                sizes[frame.anchor] = (nodes - frame.start, frame.reach - depth + 1)
            if frames:
                frames[-1].reach = max(frames[-1].reach, frame.reach)


class BoundedLoader(_FAST):
    """PyYAML's safe loader (libyaml's parser if present) for documents that passed
    :func:`check_yaml_bounds`: integers of at most :data:`MAX_INT_DIGITS` digits, and a
    scalar its tag cannot read (``!!int abc``, ``!!timestamp 2001-02-30``) is a
    :class:`yaml.YAMLError` naming it, not a ValueError."""

    def construct_object(self, node, deep=False):
        try:
            return super().construct_object(node, deep)
        except _CONSTRUCT_ERRORS:
            value = shown(node.value, 40) if isinstance(node.value, str) else '...'
            raise YamlLimitError(f"{value!r} is not a valid !!{node.tag.rsplit(':', 1)[-1]}",
                                 node.start_mark) from None

    def construct_yaml_int(self, node):
        text = self.construct_scalar(node)
        if len(text) > _MAX_INT_TEXT:
            value = None
        else:
            value = super().construct_yaml_int(node)
        if value is None or abs(value) >= 10 ** MAX_INT_DIGITS:
            digits = sum(c.isdigit() for c in text) if value is None else len(str(abs(value)))
            shown = text if len(text) <= 24 else f'{text[:24]}...'
            raise YamlLimitError(f'integer {shown} has {digits} digits, more than '
                                 f'{MAX_INT_DIGITS} (write a large number as a float, '
                                 'e.g. 1e25)', node.start_mark)
        return value


BoundedLoader.add_constructor('tag:yaml.org,2002:int', BoundedLoader.construct_yaml_int)


def parse_yaml(text: str, where: str, malformed: str = 'malformed YAML'):
    """The Python value of one YAML document of at most :data:`MAX_YAML_BYTES` (UTF-8),
    within the bounds of :func:`check_yaml_bounds`, read by :class:`BoundedLoader`.  Any
    problem is a one-line :class:`ConfigError` that starts with ``where``: ``{where}:
    {malformed} (line L, column C: what)``, or ``{where}: line L, column C: {the bound
    exceeded}``."""
    try:
        size = len(text.encode('utf-8'))
    except UnicodeEncodeError as exc:     # a lone surrogate (undecodable bytes in argv)
        raise ConfigError(f'{where}: not valid text: character {exc.start} is '
                          f'{text[exc.start]!r}') from None
    if size > MAX_YAML_BYTES:
        raise ConfigError(f'{where}: {size} bytes, more than the {MAX_YAML_BYTES} a '
                          'configuration or scenario may have')
    loader = None
    try:
        check_yaml_bounds(text)
        loader = BoundedLoader(text)
        return loader.get_single_data()
    except YamlLimitError as exc:
        raise ConfigError(f'{where}: {_yaml_problem(exc)}') from None
    except yaml.YAMLError as exc:
        raise ConfigError(f'{where}: {malformed} ({_yaml_problem(exc)})') from None
    finally:
        if loader is not None:
            loader.dispose()


def read_yaml(path):
    """The YAML value of a configuration or scenario file (None if empty), bounded as
    :func:`parse_yaml`; errors name the file."""
    text = read_text(path, MAX_YAML_BYTES, 'configuration or scenario file (1 MiB at most)')
    return parse_yaml(text, str(path))


def read_text(path, max_bytes: int, kind: str) -> str:
    """The UTF-8 text of file ``path``, at most ``max_bytes`` read: a larger file, bytes
    that are not UTF-8, NUL bytes or a file that cannot be read are one
    :class:`ConfigError` line naming the file (``kind``: what the file should have been)."""
    path = Path(path)
    try:
        with open(path, 'rb') as f:
            data = f.read(max_bytes + 1)
    except OSError as exc:
        raise ConfigError(f'{path}: cannot read: {exc.strerror or exc}') from None
    if len(data) > max_bytes:
        raise ConfigError(f'{path}: larger than {max_bytes} bytes: not a {kind}')
    try:
        text = data.decode('utf-8')
    except UnicodeDecodeError as exc:
        raise ConfigError(f'{path}: not a text (UTF-8) file: byte {exc.start} is '
                          f'{data[exc.start]:#04x}') from None
    if '\0' in text:
        raise ConfigError(f'{path}: not a text file (it contains NUL bytes)')
    return text


def shown(value, limit: int = 80) -> str:
    """``repr`` of a value for an error line, cut to ``limit`` characters."""
    text = value if isinstance(value, str) else repr(value)
    return text if len(text) <= limit else f'{text[:limit]}...({len(text)} characters)'

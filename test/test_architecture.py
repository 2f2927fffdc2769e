"""The layers of the house, checked on the sources (docs/architecture.md).

* No import cycle among drill_twin's modules, imports inside functions included (a
  deferred import hides a cycle from Python's start-up, not from a reader).
* ``drill_twin.physics`` is numerics only: it imports no other drill_twin package (the
  root's :mod:`drill_twin.errors` is the one module every layer shares), no ROS, no
  configuration-file reader.
* A compiled function (``@kernel_jit``, ``@entry_jit``, ``@njit``) takes at most 8
  arguments: the kernel passes named state, not long argument lists.
"""
import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / 'drill_twin'


def _module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix('')
    parts = list(rel.parts)
    if parts[-1] == '__init__':
        parts = parts[:-1]
    return '.'.join(parts)


def _modules() -> dict:
    return {_module_name(p): p for p in sorted(PACKAGE.rglob('*.py'))}


def _imports(name: str, path: Path, known: dict) -> set:
    """The drill_twin modules (and foreign top-level packages, prefixed ``!``) that the
    file imports anywhere in it."""
    tree = ast.parse(path.read_text())
    package = name if path.name == '__init__.py' else name.rsplit('.', 1)[0]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                found.add(alias.name if alias.name in known else f'!{alias.name.split(".")[0]}')
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split('.')
                base = base[:len(base) - node.level + 1]
                module = '.'.join(base + ([node.module] if node.module else []))
            else:
                module = node.module
            if module.split('.')[0] != 'drill_twin':
                found.add(f'!{module.split(".")[0]}')
                continue
            for alias in node.names:
                sub = f'{module}.{alias.name}'
                found.add(sub if sub in known else module)
    found.discard(name)
    return found


def _graph() -> dict:
    known = _modules()
    return {name: _imports(name, path, known) for name, path in known.items()}


def _cycles(graph: dict) -> list:
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in graph:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_no_import_cycles():
    assert _cycles(_graph()) == []


def test_the_cycle_finder_finds_one():
    assert _cycles({'a': {'b'}, 'b': {'c'}, 'c': {'a'}, 'd': {'a'}}) == [['a', 'b', 'c']]


def test_physics_imports_numerics_only():
    allowed_foreign = {'!numpy', '!numba', '!scipy', '!math', '!__future__', '!dataclasses',
                       '!typing', '!functools', '!collections', '!pathlib', '!os', '!re',
                       '!hashlib', '!shutil', '!copy', '!enum', '!sys', '!warnings',
                       '!itertools', '!llvmlite', '!cmath'}
    wrong = {}
    for name, imports in _graph().items():
        if not name.startswith('drill_twin.physics'):
            continue
        bad = {m for m in imports if not (m.startswith('drill_twin.physics')
                                          or m == 'drill_twin.errors'
                                          or m in allowed_foreign)}
        if bad:
            wrong[name] = sorted(bad)
    assert wrong == {}


def _compiled_functions():
    for path in sorted(PACKAGE.rglob('*.py')):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef):
                for dec in node.decorator_list:
                    target = dec.func if isinstance(dec, ast.Call) else dec
                    if getattr(target, 'id', getattr(target, 'attr', None)) in (
                            'kernel_jit', 'entry_jit', 'njit'):
                        yield f'{_module_name(path)}.{node.name}', len(node.args.args)


def test_compiled_functions_take_a_handful_of_arguments():
    counts = dict(_compiled_functions())
    assert len(counts) > 30                  # the kernel's functions are all found
    assert {name: n for name, n in counts.items() if n > 8} == {}

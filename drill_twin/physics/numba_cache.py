"""Where numba keeps the compiled physics kernels: a cache directory keyed by their sources.

numba's on-disk cache (``cache=True``) is keyed by the timestamp of the file of
the function it compiles, not by the files that function calls: after an edit
of a jitted helper in another module the old machine code keeps running.  To
make stale code impossible, the cache directory is named after a hash of every
source file of :mod:`drill_twin.physics` that uses numba (the jitted kernels and every
helper they call): any edit of any of them gives a new, empty directory (and a fresh
compile), whatever the timestamps say.  Jitted code above physics (the stability
module's Newton refinement) shares the directory: it calls physics helpers, whose edits
change the key, and an edit of its own file changes the timestamp numba checks.

The root is ``$NUMBA_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/drill_twin/numba``
(``~/.cache/drill_twin/numba``); ``make clean-cache`` removes it.
"""
from __future__ import annotations

import hashlib
import os
import re
import shutil
from pathlib import Path

__all__ = ['source_key', 'cache_root', 'cache_dir', 'configure', 'clear', 'is_cached']

PHYSICS_DIR = Path(__file__).resolve().parent


#: a file whose functions numba compiles: one with a decorated definition
_COMPILES = re.compile(rb'^@(kernel_jit|njit)\b', re.M)


def source_key(folder: Path = PHYSICS_DIR, others=()) -> str:
    """16 hex digits of SHA-256 over the names and contents of the ``*.py`` files of
    ``folder`` and ``others`` that numba compiles — those with a function decorated by
    ``@njit`` or the kernel's ``@kernel_jit`` — and of :mod:`drill_twin.physics.jit`, which
    holds the compiler settings.  Editing any other file (the Python API around the
    kernel, a docstring of the configuration) keeps the cache."""
    digest = hashlib.sha256()
    paths = [p for d in (folder, *others) for p in sorted(Path(d).glob('*.py'))]
    for path in paths:
        text = path.read_bytes()
        if not (_COMPILES.search(text) or path.name == 'jit.py'):
            continue
        digest.update(path.name.encode())
        digest.update(b'\0')
        digest.update(text)
        digest.update(b'\0')
    return digest.hexdigest()[:16]


def cache_root() -> Path:
    """``$NUMBA_CACHE_DIR``, or the user's cache directory for drill_twin."""
    if os.environ.get('NUMBA_CACHE_DIR'):
        return Path(os.environ['NUMBA_CACHE_DIR'])
    base = os.environ.get('XDG_CACHE_HOME') or Path.home() / '.cache'
    return Path(base) / 'drill_twin' / 'numba'


def cache_dir() -> Path:
    """The cache directory of the current physics sources."""
    return cache_root() / source_key()


def configure() -> Path:
    """Point numba at :func:`cache_dir` (before any kernel module is imported)."""
    import numba
    path = cache_dir()
    numba.config.CACHE_DIR = str(path)
    return path


def clear() -> int:
    """Remove the cache directories this module made under :func:`cache_root` (names of 16
    hex digits; nothing else there is touched).  Returns how many."""
    root = cache_root()
    removed = 0
    if root.is_dir():
        for entry in root.iterdir():
            if entry.is_dir() and re.fullmatch(r'[0-9a-f]{16}', entry.name):
                shutil.rmtree(entry, ignore_errors=True)
                removed += 1
    return removed


def is_cached(dispatcher) -> bool:
    """Whether numba's cache holds machine code of ``dispatcher`` (a ``cache=True`` jitted
    function) for this CPU: its index names an entry compiled for this machine's target
    (numba keys entries by signature and by CPU name and features)."""
    cache = getattr(dispatcher, '_cache', None)
    impl = getattr(cache, '_cache_file', None)
    if impl is None:
        return False
    try:
        index = impl._load_index()
    except Exception:  # noqa: BLE001 - an unreadable index is a cold cache
        return False
    from numba.core.registry import cpu_target
    magic = cpu_target.target_context.codegen().magic_tuple()
    return any(isinstance(key, tuple) and len(key) >= 2 and key[1] == magic for key in index)

"""Where named configurations live: the source tree's ``config/``, the installed
``share/drill_twin/config`` (pip data files, a plain colcon install) and the ament
index's share directory of the package (a colcon install found through
``AMENT_PREFIX_PATH``)."""
from __future__ import annotations

from pathlib import Path

from ..errors import ConfigError
from .yaml_bounds import shown

__all__ = ['CONFIG_DIR', 'config_dirs', 'resolve_config', 'is_file']

CONFIG_DIR = Path(__file__).resolve().parents[2] / 'config'


def config_dirs() -> list[Path]:
    """Where named configurations are looked up: the source tree, then the
    installed ``share/drill_twin/config`` (pip data_files or a colcon install)."""
    import sys
    dirs = [CONFIG_DIR, Path(sys.prefix) / 'share' / 'drill_twin' / 'config']
    try:
        from ament_index_python.packages import get_package_share_directory
        dirs.append(Path(get_package_share_directory('drill_twin')) / 'config')
    except Exception:  # noqa: BLE001 - ament index absent or package not installed
        pass
    return dirs


def resolve_config(name) -> Path:
    """The file a ``--config`` value names: a path, or a name in :func:`config_dirs`."""
    path = Path(name)
    if is_file(path):
        return path
    for folder in config_dirs():
        for candidate in (folder / path, folder / f'{path}.yaml'):
            if is_file(candidate):
                return candidate
    if _exists(path):
        raise ConfigError(f'{path}: not a file')
    known = sorted({p.stem for d in config_dirs() if d.is_dir() for p in d.glob('*.yaml')})
    raise ConfigError(f'{shown(str(name))}: no such configuration file (names in config/: '
                      f'{", ".join(known)})')


def _exists(path: Path) -> bool:
    try:
        return path.exists()
    except OSError:
        return False


def is_file(path: Path) -> bool:
    """``path.is_file()``, False where the system cannot even look (a name longer than the
    file system allows, ENAMETOOLONG): the caller then says no such file."""
    try:
        return path.is_file()
    except OSError:
        return False

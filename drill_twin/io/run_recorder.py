"""Record a :class:`~drill_twin.runtime.digital_twin.DigitalTwin` run to MCAP (no ROS needed).

Used by the twin node (parameter ``record_path``) and by ``drill-twin simulate
--out run.mcap``, so both write the same file.  Log time = simulated time
(ns from the start of the run).  What is recorded, in the order it happened:

* every set-point *as the twin applied it* (``surface_speed_setpoint``,
  ``hook_load_setpoint``, ``surface_speed_command``), at the simulated time
  it took effect, rejected ones included (they are rejected again on
  resimulation); when the controller falls silent and the twin returns to
  the operator set-point, that return is recorded as the operator set-point;
* every tick's measurement topics (one message each, ``bit/velocity`` first);
* stability advisories, diagnostics and ``/clock`` when the twin publishes them;
* the twin's run-time parameter changes (``/parameter_events``, as rclpy publishes
  them), at the simulated time they took effect: a change of
  ``max_surface_speed_rad_s`` decides which later set-points are accepted.

Because the order and the simulated times are exact, feeding the recorded
set-points into a fresh twin reproduces the run
(:func:`drill_twin.io.resimulation.resimulate`).  The run description goes in
the MCAP metadata record ``drill_twin``: the full resolved configuration
(JSON), the twin's settings, package version, model and git revision.
"""
from __future__ import annotations

import datetime
import json
import subprocess
from importlib import metadata as importlib_metadata
from pathlib import Path

from ..errors import ParameterError
from ..topics import (
    BY_NAME,
    clock_fields,
    measurement_messages,
    parameter_event_fields,
    stamp_fields,
)
from .mcap_reader import RUN_METADATA
from .mcap_writer import McapRecorder

__all__ = ['TwinRecorder', 'package_version', 'git_revision', 'qualified', 'run_metadata']

FORMAT = 'drill_twin.recording/1'


def package_version() -> str:
    try:
        return importlib_metadata.version('drill_twin')
    except importlib_metadata.PackageNotFoundError:  # pragma: no cover - source tree only
        return 'unknown'


def git_revision() -> str:
    """The source tree's git revision (``+dirty`` if modified); for an installed copy (colcon,
    pip), the revision its install recorded in ``share/drill_twin/git_revision``; '' when
    unknown."""
    return _checkout_revision() or _installed_revision()


def _installed_revision() -> str:
    import sys
    candidates = [Path(sys.prefix) / 'share' / 'drill_twin' / 'git_revision',
                  Path(__file__).resolve().parents[2] / 'resource' / 'git_revision']
    try:
        from ament_index_python.packages import get_package_share_directory
        candidates.insert(0, Path(get_package_share_directory('drill_twin')) / 'git_revision')
    except Exception:  # noqa: BLE001 - no ament index, or the package is not in it
        pass
    for path in candidates:
        try:
            text = path.read_text().strip()
        except OSError:
            continue
        if text:
            return f'{text} (installed)'
    return ''


def _checkout_revision() -> str:
    here = Path(__file__).resolve().parent

    def git(*args):
        return subprocess.run(['git', *args], cwd=here, capture_output=True, text=True,
                              timeout=5, check=True).stdout.strip()
    try:
        top = Path(git('rev-parse', '--show-toplevel'))
        if (top / 'drill_twin' / 'io' / Path(__file__).name).resolve() != Path(__file__).resolve():
            return ''  # e.g. installed into a workspace that happens to be a git repository
        dirty = git('status', '--porcelain', '--untracked-files=no')
        return git('rev-parse', 'HEAD') + ('+dirty' if dirty else '')
    except (OSError, subprocess.SubprocessError):
        return ''


def run_metadata(time_base: str, namespace: str, **fields) -> dict:
    """The ``drill_twin`` metadata record: what every recording carries (format, time base,
    package version, git revision, creation time, namespace) plus ``fields``."""
    return {'format': FORMAT, 'time_base': time_base, 'package_version': package_version(),
            'git_revision': git_revision(),
            'created_utc': datetime.datetime.now(datetime.UTC).isoformat(),
            'namespace': namespace, **fields}


def qualified(name: str, namespace: str = '/') -> str:
    """Fully qualified topic name (rosbag2 stores absolute names)."""
    if name.startswith('/'):
        return name
    return namespace.rstrip('/') + '/' + name


class TwinRecorder:
    """Records one twin run (see module docstring).

    Parameters
    ----------
    path : str or Path
        Output ``.mcap`` file.
    twin : DigitalTwin
        The twin whose run is recorded.
    config : str
        Configuration name or path the twin was built from (for the record).
    overrides : list of str
        Configuration overrides (for the record).
    namespace : str
        ROS namespace of the twin's topics.
    node : str
        Fully qualified name of the twin node (the ``node`` of its parameter events).
    settings : dict
        Extra run settings (publish rate, real-time factor, ...) stored verbatim.
    chunk_period_s : float
        Most log time / wall time one chunk holds [s] (what a SIGKILL can lose).
    """

    def __init__(self, path, twin, config: str = '', overrides=(), namespace: str = '/',
                 settings: dict | None = None, chunk_period_s: float = 0.25,
                 node: str = '/drill_twin'):
        self.twin = twin
        self.namespace = namespace
        self.node = node
        self.writer = McapRecorder(path, chunk_period_s=chunk_period_s,
                                   library=f'drill_twin {package_version()}')
        self.writer.add_metadata(RUN_METADATA, run_metadata(
            'simulated', namespace, config=str(config), overrides=json.dumps(list(overrides)),
            node=node, model=twin.scenario.model.name, scenario=json.dumps(twin.scenario.raw),
            twin=json.dumps(twin.settings()), settings=json.dumps(settings or {})))

        self._held = None
        #: why recording stopped (a write failed: the disk is full, ...), None while it runs
        self.failure: str | None = None

    @property
    def path(self):
        return self.writer.path

    def _guarded(self, action, *args):
        """Run a write of the writer; an OSError (ENOSPC, EACCES, EIO) stops the recording
        — the twin it records goes on — and is kept in :attr:`failure`."""
        if self.failure is not None:
            return
        try:
            action(*args)
        except OSError as exc:
            self.failure = f'{self.path}: {exc.strerror or exc}'
            self.writer.abandon()

    def hold(self):
        """Simulated time is held (the twin paused or inactive): set-points applied from now
        on are kept, the last of each topic, and written by :meth:`release` — a controller
        streaming commands at 100 Hz into a held twin would otherwise fill the file with
        messages at one instant, which a replay plays as a burst.  The twin's state when
        time resumes is that of the last value of each (kept in the order they were last
        applied), so resimulation is unchanged."""
        if self._held is None:
            self._held = {}

    def release(self):
        """Time runs again: write the set-points kept while held (at the current time)."""
        held, self._held = self._held, None
        for name, value in (held or {}).items():
            self._write(name, {'data': value}, self.twin.time_s)

    def _write(self, name, fields, time_s):
        topic = BY_NAME[name]
        self._guarded(self.writer.write, qualified(name, self.namespace), topic.type,
                      topic.qos, fields, int(round(time_s * 1e9)))

    def measurements(self, m: dict, stamp: dict | None = None, messages=None):
        """One tick: every measurement topic at the tick's simulated time.
        ``stamp``: the header stamp the node published with (default: simulated time);
        ``messages``: the tick's :func:`~drill_twin.topics.measurement_messages` when the
        caller has built them already (the node, to publish them)."""
        if messages is None:
            messages = measurement_messages(m, stamp or stamp_fields(m['time_s']))
        for topic, fields in messages:
            self._write(topic.name, fields, m['time_s'])

    def setpoint(self, name: str, value: float):
        """A set-point as the twin applied (or rejected) it, at the twin's current time."""
        if BY_NAME[name].role != 'setpoint':
            raise ValueError(f'{name} is not a set-point topic')
        if self._held is not None:
            self._held.pop(name, None)    # re-inserted last: the order of the last values
            self._held[name] = float(value)
            return
        self._write(name, {'data': float(value)}, self.twin.time_s)

    def event(self, name: str, fields: dict, time_s: float | None = None):
        """An advisory or diagnostics message (fields as in :mod:`drill_twin.topics`)."""
        self._write(name, fields, self.twin.time_s if time_s is None else time_s)

    def parameters(self, params):
        """Run-time parameter changes (objects with ``name`` and ``value``, e.g. rclpy
        ``Parameter``), as one ``/parameter_events`` message at the twin's current time."""
        time_s = self.twin.time_s
        self._write('/parameter_events', parameter_event_fields(
            stamp_fields(time_s), self.node, {p.name: p.value for p in params}), time_s)

    def clock(self, time_s: float):
        self._write('/clock', clock_fields(time_s), time_s)

    def flush(self):
        self._guarded(self.writer.flush)

    def close(self):
        self.release()
        self._guarded(self.writer.close)


def record_run(scenario, path, duration_s: float, rate_hz: float = 100.0, config: str = '',
               overrides=(), progress=None, chunk_period_s: float = 0.25, stop=None,
               observe=None) -> dict:
    """Run an SI scenario offline as the twin node would (same ticks, same topics, the 3-D
    view included) and record it; ``progress(fraction)`` is called as it goes; ``stop()`` ->
    True ends the run after the current tick (what a signal handler should set: an exception
    raised in the middle of a write would leave the writer's indexes inconsistent);
    ``observe(session)`` is called with the :class:`~drill_twin.runtime.session.TickSession`
    before the first set-point (the live view attaches its listeners there).  The recording
    is closed properly in any case.  Returns counts (``stopped``: ended by ``stop``)."""
    from ..runtime.session import TickSession
    if not (rate_hz > 0 and duration_s > 0):
        raise ParameterError(f'need rate_hz > 0 and duration_s > 0, got {rate_hz}, {duration_s}')
    # the integration step divides the tick, as in the node: samples every 1/rate_hz exactly
    twin = TickSession.aligned_twin(scenario, rate_hz)
    rec = TwinRecorder(path, twin, config, overrides, chunk_period_s=chunk_period_s,
                       settings={'publish_rate_hz': rate_hz, 'source': 'drill-twin simulate'})
    session = TickSession(twin, rate_hz, rec)
    ticks = int(round(duration_s * rate_hz))
    stopped = False
    try:  # the operator set-points in force, recorded as applied at t = 0
        if observe is not None:
            observe(session)
        session.record_scene()
        session.apply('surface_speed_setpoint', twin.surface_speed_setpoint)
        session.apply('hook_load_setpoint', twin.hook_load_N)
        for k in range(1, ticks + 1):
            if stop is not None and stop():
                stopped = True
                break
            session.tick(k / rate_hz)
            if progress is not None and k % 100 == 0:
                progress(k / ticks)
    finally:
        session.close()
    if progress is not None and not stopped:
        progress(1.0)
    return {'stopped': stopped, 'ticks': ticks, 'messages': rec.writer.messages_written,
            'path': str(rec.path), 'simulated_s': twin.time_s}

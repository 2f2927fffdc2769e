"""Resimulate a recorded run: recorded set-points into a fresh twin, outputs compared.

The twin's recorder writes set-points when (and in the order) the twin
applied them and one group of measurement messages per tick, all at exact
simulated times (:mod:`drill_twin.io.run_recorder`).  Walking the file in
write order, this module rebuilds the twin from the recorded configuration
(metadata ``drill_twin``), applies each set-point (rejected ones are rejected
again) and each run-time change of ``max_surface_speed_rad_s`` (which decides
what is rejected), and at each tick advances by the same number of steps and compares
every numeric field of every measurement message with the fresh twin's.
Same package version and configuration => every difference is exactly 0.
"""
from __future__ import annotations

from ..config.scenario import scenario_from_dict
from ..runtime.digital_twin import DigitalTwin
from ..runtime.session import TickSession
from ..topics import BY_NAME, MEASUREMENTS, TOPICS, parameter_value
from .export import flatten
from .mcap_reader import Recording, RecordingError
from .run_recorder import qualified

__all__ = ['resimulate']

def _leaves(fields: dict, prefix=''):
    for key, value in fields.items():
        if key == 'header':
            continue  # stamps are ROS time in a real-time run, not compared
        if isinstance(value, dict):
            yield from _leaves(value, f'{prefix}{key}.')
        elif isinstance(value, (list, tuple)):   # e.g. JointState arrays; names are labels
            for i, item in enumerate(value):
                if isinstance(item, dict):
                    yield from _leaves(item, f'{prefix}{key}[{i}].')
                elif not isinstance(item, str):
                    yield f'{prefix}{key}[{i}]', float(item)
        elif not isinstance(value, str):
            yield f'{prefix}{key}', float(value)


def _pick(flat: dict, key: str):
    """A leaf of :func:`~drill_twin.io.export.flatten`'s output by a :func:`_leaves` key
    (``position[2]`` is element 2 of the array field ``position``)."""
    if key in flat:
        return flat[key]
    name, _, index = key.rpartition('[')
    return flat[name][int(index.rstrip(']'))]


def resimulate(recording: Recording, apply_setpoints: bool = True) -> dict:
    """Rerun a recording's twin with its set-points; largest difference per topic.

    Parameters
    ----------
    recording : Recording
        A file written by the twin's recorder (``record_path``) or ``drill-twin
        simulate --out``.
    apply_setpoints : bool
        False skips the recorded set-points (to show that they matter).

    Returns
    -------
    dict
        ``topics``: ``{topic: {'messages': n, 'max_abs_difference': d}}`` (SI units of
        each field), ``ticks``, ``setpoints_applied``, ``setpoints_rejected``,
        ``max_time_difference_s``.
    """
    run = recording.run
    if not run.get('scenario') or run.get('time_base') != 'simulated':
        raise RecordingError(
            f'{recording.path}: no twin configuration on simulated time in this recording '
            '(files of mcap_recorder can be replayed, not resimulated): record with the twin '
            "node's record_path parameter or `drill-twin simulate --out run.mcap`")
    try:
        twin = DigitalTwin(scenario_from_dict(run['scenario']), **run['twin'])
    except (ValueError, TypeError, KeyError) as exc:
        raise RecordingError(f'{recording.path}: recorded configuration rejected: {exc}') \
            from None
    # the recorded set-points and ticks drive the twin through the loop the recording came
    # from; every tick names its instant (the period given here is never used)
    session = TickSession(twin, 100.0)
    ns = run.get('namespace', '/')
    spec = {qualified(t.name, ns): t for t in TOPICS if t.role in ('setpoint', 'measurement')}
    spec['/parameter_events'] = BY_NAME['/parameter_events']
    node = run.get('node', '/drill_twin')
    first = qualified(MEASUREMENTS[0].name, ns)
    report = {name: {'messages': 0, 'max_abs_difference': 0.0}
              for name in spec if spec[name].role == 'measurement'}
    ticks = applied = rejected = 0
    time_diff = 0.0
    expected = {}
    for topic, t_ns, data in recording.messages(spec):
        topic_spec = spec[topic]
        msg = recording.decoder(topic)(data)
        if topic_spec.role == 'parameters':
            if msg.node == node:
                for prm in msg.changed_parameters:
                    if prm.name == 'max_surface_speed_rad_s':
                        twin.max_surface_speed = float(parameter_value(prm.value))
            continue
        if topic_spec.role == 'setpoint':
            if not apply_setpoints:
                continue
            if session.apply(topic_spec.name, msg.data) is None:
                applied += 1
            else:
                rejected += 1
            continue
        if topic == first:  # a new tick: as many whole steps as the recording advanced
            steps = round((t_ns * 1e-9 - twin.time_s) / twin.step_s)
            m = session.tick(twin.time_s + (steps + 0.5) * twin.step_s, max_steps=steps) \
                if steps > 0 else None
            m = m if m is not None else twin.measurements()
            time_diff = max(time_diff, abs(t_ns * 1e-9 - twin.time_s))
            expected = {qualified(t.name, ns): t.fields(m, {}) for t in MEASUREMENTS}
            ticks += 1
        if topic not in expected:
            raise RecordingError(f'{recording.path}: {topic} before the first {first}')
        got = flatten(msg)
        diff = max((abs(v - float(_pick(got, k))) for k, v in _leaves(expected[topic])),
                   default=0.0)
        entry = report[topic]
        entry['messages'] += 1
        entry['max_abs_difference'] = max(entry['max_abs_difference'], diff)
    return {'topics': {k: v for k, v in report.items() if v['messages']}, 'ticks': ticks,
            'setpoints_applied': applied, 'setpoints_rejected': rejected,
            'max_time_difference_s': time_diff}

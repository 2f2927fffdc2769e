"""An offline run served live: ``drill-twin simulate --live`` and ``scenario run --live``.

:class:`PacedFeed` attaches to a :class:`~drill_twin.runtime.session.TickSession` (the loop
the offline commands share): after every tick it hands the measurement topics, and at a few
Hz the 3-D view, to a :class:`~drill_twin.live.server.LiveView`, and holds the loop to the
wall clock (``real_time_factor`` simulated seconds per wall second; on a fixed grid, so
that a late tick does not shift the next ones).  Header stamps and log times are wall-clock
times (ns since the epoch) of the simulated instants, as the twin node publishes them.
"""
from __future__ import annotations

import time

from .. import topics as T
from ..runtime.scene import StringScene

__all__ = ['PacedFeed', 'live_topics', 'run_live']


def live_topics(clock: bool = False) -> list:
    """The topics the twin serves live (``/clock`` only when it runs as fast as possible)."""
    roles = set(T.LIVE_ROLES) - (set() if clock else {'clock'})
    return [t for t in T.TOPICS if t.role in roles]


class PacedFeed:
    """Feeds a :class:`LiveView` from a session's ticks, in real time (module docstring).

    Parameters
    ----------
    view : LiveView
        The server.
    real_time_factor : float
        Simulated seconds per wall second; ``inf`` = unpaced.
    clock, sleep, wall_ns : callables
        Steady clock [s], sleep [s] and the wall clock [ns] (tests inject them).
    """

    def __init__(self, view, real_time_factor: float = 1.0, clock=time.monotonic,
                 sleep=time.sleep, wall_ns=time.time_ns):
        self.view = view
        self.real_time_factor = float(real_time_factor)
        self._clock, self._sleep, self._wall_ns = clock, sleep, wall_ns
        self.scene = None
        self.session = None
        self._t0 = self._sim0 = None
        self._epoch_ns = 0
        #: ticks that ended after their wall-clock deadline
        self.late = 0
        self.ticks = 0

    def attach(self, session):
        """Listen to ``session`` (its set-points as applied, its ticks); the latched scene
        is served now."""
        self.session = session
        self.scene = StringScene(session.twin)
        self._t0, self._sim0 = self._clock(), session.twin.time_s
        self._epoch_ns = self._wall_ns()
        session.listeners.append(self._applied)
        session.tick_listeners.append(self.tick)
        stamp = self.stamp_ns(self._sim0)
        for name, fields in self.scene.static_messages(T.stamp_fields(ns=stamp)):
            self.view.publish(name, fields, stamp)

    def stamp_ns(self, time_s: float) -> int:
        """Wall-clock time [ns] of the simulated instant ``time_s`` [s]."""
        return self._epoch_ns + int(round((time_s - self._sim0) / self.real_time_factor * 1e9))

    def _applied(self, name, value, error):
        self.view.setpoint(name, value, self.stamp_ns(self.session.twin.time_s))

    def tick(self, m: dict):
        """After a tick: serve its messages, then wait for its wall-clock instant."""
        ns = self.stamp_ns(m['time_s'])
        stamp = T.stamp_fields(ns=ns)
        self.view.publish_all(T.measurement_messages(m, stamp), ns)
        for name, fields in self.scene.messages(m, stamp):
            self.view.publish(name, fields, ns)
        self.ticks += 1
        due = self._t0 + (m['time_s'] - self._sim0) / self.real_time_factor
        wait = due - self._clock()
        if wait > 0:
            self._sleep(wait)
        else:
            self.late += 1


def run_live(scenario, duration_s: float, feed: PacedFeed, rate_hz: float = 100.0,
             stop=None) -> dict:
    """Run an SI scenario for ``duration_s`` [s] of simulated time at ``rate_hz`` [Hz],
    served by ``feed`` (nothing recorded: :func:`drill_twin.io.run_recorder.record_run`
    with ``observe=feed.attach`` records too); ``stop()`` -> True ends it after a tick."""
    from ..runtime.session import TickSession
    twin = TickSession.aligned_twin(scenario, rate_hz)
    twin.warm_up()
    session = TickSession(twin, rate_hz)
    feed.attach(session)
    session.apply_initial_setpoints()
    ticks = int(round(duration_s * rate_hz))
    stopped = False
    for k in range(1, ticks + 1):
        if stop is not None and stop():
            stopped = True
            break
        session.tick(k / rate_hz)
    return {'stopped': stopped, 'ticks': feed.ticks, 'late_ticks': feed.late,
            'simulated_s': twin.time_s, 'live_messages': feed.view.sent}

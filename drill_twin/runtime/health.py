"""Health of a running node over the recent past (no ROS).

A rig operator reads ``/diagnostics`` as "is something wrong *now*": a counter
that only ever grows turns WARN on for good after the first hiccup.  Events
(overruns, slips, rejected set-points, fallbacks, ...) are therefore counted
in a sliding window (10 s by default) for the level, and in lifetime totals
for the values.

Levels follow ``diagnostic_msgs/DiagnosticStatus``: 0 OK, 1 WARN, 2 ERROR.
"""
from __future__ import annotations

from collections import deque

__all__ = ['EventWindow', 'OK', 'WARN', 'ERROR', 'worst', 'human']

OK, WARN, ERROR = 0, 1, 2


class EventWindow:
    """Counts of named events in the last ``window_s`` seconds, and since the start.

    Memory is bounded by the number of ``add`` calls within one window.
    """

    def __init__(self, window_s: float = 10.0):
        if not window_s > 0:
            raise ValueError(f'window_s must be > 0, got {window_s}')
        self.window_s = float(window_s)
        self._events: deque = deque()
        self._recent: dict[str, int] = {}
        self.totals: dict[str, int] = {}

    def add(self, kind: str, now_s: float, count: int = 1):
        """Record ``count`` events of ``kind`` at time ``now_s``."""
        if count <= 0:
            return
        self._prune(now_s)
        self._events.append((now_s, kind, count))
        self._recent[kind] = self._recent.get(kind, 0) + count
        self.totals[kind] = self.totals.get(kind, 0) + count

    def recent(self, kind: str, now_s: float) -> int:
        """Events of ``kind`` within the window ending at ``now_s``."""
        self._prune(now_s)
        return self._recent.get(kind, 0)

    def total(self, kind: str) -> int:
        return self.totals.get(kind, 0)

    def _prune(self, now_s: float):
        while self._events and self._events[0][0] < now_s - self.window_s:
            _, kind, count = self._events.popleft()
            self._recent[kind] -= count


def worst(*findings):
    """The highest-level ``(level, reason)`` of the findings (``(OK, 'running')`` if none);
    reasons of the same level are joined."""
    found = [f for f in findings if f is not None]
    if not found:
        return OK, 'running'
    level = max(lvl for lvl, _ in found)
    return level, '; '.join(reason for lvl, reason in found if lvl == level)


def human(value) -> str:
    """A diagnostics value as a person reads it: integers as is, floats to 4 significant
    digits, booleans lower case."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return f'{value:.4g}'
    return str(value)

"""What a client may do, and what happens when it stops (plain classes: no asyncua, no ROS).

* :func:`check_write`: a write is validated like a ROS set-point: a value of the wrong type
  is ``BadTypeMismatch``, NaN, +-inf or out of the variable's range ``BadOutOfRange``; the
  last valid value stays.
* :class:`ControlArbiter`: one client at a time holds control of a function (rotation,
  hoisting), taken with ``RequestControl``; a write from a session that does not hold it
  is ``BadUserAccessDenied``.  The holder feeds the function's heartbeat at least every
  ``MaxRefreshDelay``; when it falls silent longer, :meth:`ControlArbiter.expired` says so
  once, the caller puts the function in its safe state (:data:`SAFE_STATE`) and control is
  back with the operator (ROS).  An operator set-point on ROS takes control back at once,
  as it stops a running scenario in the twin.
* :class:`BurstLog`: rejected writes are logged once per burst, not once per write.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..runtime.arbitration import Watchdog
from .address_space import FUNCTIONS, Variable

__all__ = ['Refusal', 'check_write', 'ControlArbiter', 'BurstLog', 'SAFE_STATE',
           'NUMERIC_TYPES', 'INTEGER_TYPES']

#: variant types a Double variable accepts
NUMERIC_TYPES = frozenset({'Double', 'Float', 'SByte', 'Byte', 'Int16', 'UInt16', 'Int32',
                           'UInt32', 'Int64', 'UInt64'})
#: variant types a counter (UInt32 / Int32) accepts
INTEGER_TYPES = frozenset({'SByte', 'Byte', 'Int16', 'UInt16', 'Int32', 'UInt32', 'Int64',
                           'UInt64'})

#: the safe state of each function after a heartbeat loss, and why (docs/opcua.md)
SAFE_STATE = {
    'rotation': 'hold the last speed set-point, control back to the operator: stopping the '
                'top drive with the string wound up releases its torque as backspin, and a '
                'string that stops turning on bottom risks sticking; a rig hands the drive '
                'back to the driller at its current speed',
    'hoisting': 'block velocity set-point 0 (blocks stop: the block must not keep travelling '
                'unsupervised), hook-load set-point held; control back to the operator',
}


@dataclass(frozen=True)
class Refusal:
    """Why a write is refused: an OPC UA status name and one line for the log."""

    status: str
    reason: str


def check_write(var: Variable, variant_type: str, value) -> Refusal | None:
    """Validate a client's write of ``value`` (of OPC UA variant type ``variant_type``) to
    ``var``; None if it may be applied.

    Parameters
    ----------
    var : Variable
        The target (its ``kind``, ``low``/``high`` in SI units).
    variant_type : str
        The variant type the client sent (``'Double'``, ``'String'``, ...).
    value : object
        The value sent.

    Returns
    -------
    Refusal or None
    """
    if not var.writable:
        return Refusal('BadNotWritable', f'{var.key} is not writable')
    accepted = NUMERIC_TYPES if var.kind == 'Double' else INTEGER_TYPES
    if variant_type not in accepted or isinstance(value, (bool, str, bytes)) or \
            not isinstance(value, (int, float)):
        return Refusal('BadTypeMismatch', f'{var.key} takes a {var.kind}, got a '
                       f'{variant_type} {_short(value)}')
    if not math.isfinite(value):
        return Refusal('BadOutOfRange', f'{var.key} = {value} is not finite')
    low = -math.inf if var.low is None else var.low
    high = math.inf if var.high is None else var.high
    if not low <= value <= high:
        return Refusal('BadOutOfRange', f'{var.key} = {value:g} outside [{low:g}, {high:g}]'
                       f'{_unit(var)}')
    return None


def _unit(var):
    from .address_space import UNITS
    return f' {UNITS[var.unit][0]}' if var.unit in UNITS else ''


def _short(value, n=40) -> str:
    text = repr(value)
    return text if len(text) <= n else text[:n] + '...'


@dataclass
class _Holder:
    client: str
    session: object
    watchdog: Watchdog


class ControlArbiter:
    """Who holds control of each function (see module docstring).

    Parameters
    ----------
    max_refresh_delay_s : float
        Initial ``MaxRefreshDelay`` of every function [s].
    """

    def __init__(self, max_refresh_delay_s: float = 0.5):
        self.max_refresh_delay_s = {f: float(max_refresh_delay_s) for f in FUNCTIONS}
        self._holders: dict[str, _Holder] = {}

    @staticmethod
    def known(function: str) -> bool:
        return function in FUNCTIONS

    def holder(self, function: str) -> str:
        """The client holding ``function``, '' for the operator."""
        h = self._holders.get(function)
        return h.client if h is not None else ''

    def granted(self, function: str) -> bool:
        return function in self._holders

    def holds(self, function: str, session) -> bool:
        h = self._holders.get(function)
        return h is not None and h.session is session

    def request(self, function: str, client: str, session, now_s: float) -> tuple:
        """``RequestControl``: ``(granted, message)``; the heartbeat clock starts now."""
        client = ' '.join(str(client).split())[:64] or 'client'
        h = self._holders.get(function)
        if h is not None and h.session is not session:
            return False, f'{function} is held by {h.client}'
        dog = Watchdog(self.max_refresh_delay_s[function])
        dog.feed(now_s)
        self._holders[function] = _Holder(client, session, dog)
        return True, (f'{function} granted to {client}: write Heartbeat at least every '
                      f'{self.max_refresh_delay_s[function]:g} s')

    def release(self, function: str, session) -> bool:
        """``ReleaseControl`` by the holder's session; True if it held the function."""
        if not self.holds(function, session):
            return False
        del self._holders[function]
        return True

    def take_back(self, function: str) -> str:
        """The operator (ROS) takes control back; the client that lost it ('' if none)."""
        h = self._holders.pop(function, None)
        return h.client if h is not None else ''

    def drop_session(self, session) -> list:
        """Functions a closed session held (released)."""
        gone = [f for f, h in self._holders.items() if h.session is session]
        for f in gone:
            del self._holders[f]
        return gone

    def heartbeat(self, function: str, now_s: float):
        h = self._holders.get(function)
        if h is not None:
            h.watchdog.feed(now_s)

    def set_max_refresh_delay(self, function: str, delay_s: float):
        self.max_refresh_delay_s[function] = float(delay_s)
        h = self._holders.get(function)
        if h is not None:
            h.watchdog.timeout_s = float(delay_s)

    def deadline(self) -> float | None:
        """The earliest instant a holder's silence would expire [s, monotonic]."""
        times = [h.watchdog.last_s + h.watchdog.timeout_s for h in self._holders.values()
                 if h.watchdog.last_s is not None]
        return min(times) if times else None

    def expired(self, now_s: float) -> list:
        """``(function, client, silence_s)`` of each holder silent for longer than its
        ``MaxRefreshDelay`` (control is returned to the operator: reported once)."""
        out = []
        for function, h in list(self._holders.items()):
            last = h.watchdog.last_s
            if h.watchdog.expired(now_s):
                del self._holders[function]
                out.append((function, h.client, now_s - last))
        return out


class BurstLog:
    """Log a kind of event once per burst: the first of a burst is said at once, the ones
    that follow within ``quiet_s`` of each other are counted and summed up in the line of
    the next burst.

    Parameters
    ----------
    quiet_s : float
        Silence that ends a burst [s].
    """

    def __init__(self, quiet_s: float = 1.0):
        self.quiet_s = float(quiet_s)
        self._last = None
        self._held = 0
        self.total = 0

    def add(self, now_s: float, line: str) -> str | None:
        """The line to log for this event, or None (inside a burst: counted)."""
        self.total += 1
        in_burst = self._last is not None and now_s - self._last <= self.quiet_s
        self._last = now_s
        if in_burst:
            self._held += 1
            return None
        held, self._held = self._held, 0
        more = f' ({held} more refused in the previous burst)' if held else ''
        return line + more

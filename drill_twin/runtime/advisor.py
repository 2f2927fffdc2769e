"""The stability advisory, computed in a worker process of its own (no ROS).

The advisory (spectral abscissa of the linearised model and critical surface
speed at the current set-points, :mod:`drill_twin.stability.spectrum`) takes
0.1-2 s of CPU.  In a thread of the twin it held the interpreter and stalled the
real-time loop; here it runs in a separate Python process:

* started with ``python -m drill_twin.runtime.advisor --parent PID`` in a session of its own
  (a Ctrl-C in the terminal goes to the node, which ends the worker), at a lower
  scheduling priority (``nice`` +10) than the loop;
* the protocol is one JSON object per line on the worker's stdin/stdout: first
  the configuration (the resolved scenario mapping), then requests
  ``{"id", "surface_speed_rad_s", "weight_on_bit_N"}``, answered by
  ``{"id", "spectral_abscissa_1_s", "critical_surface_speed_rad_s"}`` or
  ``{"id", "error"}``;
* the node never waits: :meth:`StabilityAdvisor.request` returns at once (one
  request in flight at a time) and :meth:`StabilityAdvisor.poll` reads a finished
  answer if there is one;
* the worker ends when its stdin closes (the node exited or was killed), and
  :meth:`StabilityAdvisor.close` terminates it without waiting for a computation.
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

__all__ = ['StabilityAdvisor', 'advise']

_PACKAGE_PARENT = str(Path(__file__).resolve().parents[2])


class StabilityAdvisor:
    """Client of the advisory worker process.

    Parameters
    ----------
    scenario : dict
        The resolved configuration mapping (``Scenario.raw``) of an SI scenario.
    python : str
        Interpreter that runs the worker (default: this one).
    """

    def __init__(self, scenario: dict, python: str = sys.executable):
        env = dict(os.environ)
        env['PYTHONPATH'] = os.pathsep.join(p for p in (_PACKAGE_PARENT,
                                                        env.get('PYTHONPATH')) if p)
        self._proc = subprocess.Popen(
            [python, '-m', 'drill_twin.runtime.advisor', '--parent', str(os.getpid())],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, env=env, start_new_session=True)
        os.set_blocking(self._proc.stdout.fileno(), False)
        self._buffer = b''
        self._next_id = 0
        self.pending = None      # id of the request in flight
        self.failure = ''        # why the worker stopped, if it did
        self._send({'scenario': scenario})

    @property
    def busy(self) -> bool:
        return self.pending is not None

    @property
    def alive(self) -> bool:
        return not self.failure and self._proc.poll() is None

    def _send(self, obj):
        try:
            self._proc.stdin.write((json.dumps(obj) + '\n').encode())
            self._proc.stdin.flush()
            return True
        except (BrokenPipeError, OSError, ValueError) as exc:
            self.failure = f'worker gone ({type(exc).__name__})'
            return False

    def request(self, surface_speed_rad_s: float, weight_on_bit_N: float) -> bool:
        """Ask for the advisory at these set-points; False (nothing sent) while busy or dead."""
        if self.busy or not self.alive:
            return False
        self._next_id += 1
        if self._send({'id': self._next_id, 'surface_speed_rad_s': float(surface_speed_rad_s),
                       'weight_on_bit_N': float(weight_on_bit_N)}):
            self.pending = self._next_id
            return True
        return False

    def poll(self) -> dict | None:
        """The answer to the request in flight if it has arrived (never blocks)."""
        if self.pending is None:
            return None
        try:
            chunk = self._proc.stdout.read()
        except (OSError, ValueError):
            chunk = None
        if chunk:
            self._buffer += chunk
        elif chunk == b'' and self._proc.poll() is not None:
            self.failure = f'worker exited with code {self._proc.returncode}'
            self.pending = None
            return None
        while b'\n' in self._buffer:
            line, self._buffer = self._buffer.split(b'\n', 1)
            try:
                answer = json.loads(line)
            except json.JSONDecodeError:
                continue
            if answer.get('id') == self.pending:
                self.pending = None
                return answer
        return None

    def close(self, timeout_s: float = 0.3):
        """End the worker now (it may be in the middle of a computation)."""
        proc = self._proc
        if proc.poll() is None:
            try:
                proc.stdin.close()
            except OSError:
                pass
            proc.terminate()
            try:
                proc.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        for stream in (proc.stdin, proc.stdout):
            try:
                stream.close()
            except OSError:
                pass
        self.failure = self.failure or 'closed'


# --- the worker ------------------------------------------------------------------------

def advise(scenario, surface_speed_rad_s: float, weight_on_bit_N: float) -> dict:
    """Spectral abscissa [1/s] and critical surface speed [rad/s] (NaN if none) of an SI
    scenario at the given set-points."""
    from ..stability.spectrum import critical_speed, spectral_abscissa
    groups = scenario.system.groups(max(surface_speed_rad_s, 1e-6), weight_on_bit_N)
    t_star = scenario.scales.time_s
    abscissa = spectral_abscissa(scenario.model, groups) / t_star
    wc = critical_speed(scenario.model, groups, 0.2, 60.0 * t_star, samples=12, rtol=1e-3)
    return {'spectral_abscissa_1_s': float(abscissa),
            'critical_surface_speed_rad_s': float(wc / t_star) if wc is not None else math.nan}


def _worker(stdin, stdout):
    from ..config.scenario import scenario_from_dict
    from ..errors import ParameterError
    first = stdin.readline()
    if not first:
        return 0
    scenario = scenario_from_dict(json.loads(first)['scenario'])
    for line in stdin:
        request = json.loads(line)
        answer = {'id': request['id']}
        try:
            answer.update(advise(scenario, request['surface_speed_rad_s'],
                                 request['weight_on_bit_N']))
        except (ParameterError, ValueError, ArithmeticError) as exc:
            answer['error'] = str(exc)
        stdout.write(json.dumps(answer) + '\n')
        stdout.flush()
    return 0


def main() -> int:
    try:
        os.nice(10)
    except OSError:
        pass
    try:
        return _worker(sys.stdin, sys.stdout)
    except (BrokenPipeError, KeyboardInterrupt):
        return 0


if __name__ == '__main__':
    sys.exit(main())

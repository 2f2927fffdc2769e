"""``drill-twin``: the offline command-line tool.

Sub-commands
------------
``simulate``   run a configuration, write the time series (npz), print a summary
``config``     the configuration schema (every key, unit, range), or check a file
``params``     print the SI scales and every derived dimensionless group
``stability``  characteristic roots / critical speed of the linearised model
``demo``       the main job of ``make demo``: the benchmark run(s) with outputs
``reproduce``  regenerate the thesis's computable figures (docs/reproduction.md)
``scenario``   run a timeline of rig operations (connection, start-up ...), draw them
``mcap``       inspect / recover / export / plot a recording
``replay``     republish a recording with its timing, or resimulate it
"""
from __future__ import annotations

import argparse
import os
import signal
import sys
import threading

from . import recording_cli
from .config import cli as config_cli
from .control import cli as control_cli
from .errors import ParameterError
from .estimation import cli as estimation_cli
from .io.mcap_reader import RecordingError
from .opcua import cli as opcua_cli
from .operations import cli as operations_cli
from .physics.simulation import SimulationDiverged
from .reproduce import cli as reproduce_cli
from .runtime import cli as runtime_cli
from .runtime.digital_twin import SetpointError
from .stability import cli as stability_cli
from .sweep import cli as sweep_cli
from .wells import cli as wells_cli

#: who owns which sub-commands, in the order ``drill-twin -h`` lists them
PACKAGES = (runtime_cli, config_cli, stability_cli, reproduce_cli, recording_cli,
            operations_cli, estimation_cli, control_cli, sweep_cli, wells_cli, opcua_cli)


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (no usage block): ``drill-twin simulate: error: ...``"""

    def error(self, message):
        self.exit(2, f'{self.prog}: error: {" ".join(message.split())} (see {self.prog} -h)\n')


def build_parser() -> argparse.ArgumentParser:
    """The ``drill-twin`` parser: each package registers its own sub-commands."""
    p = _Parser(prog='drill-twin', description='The offline tool of drill_twin, the digital '
                'twin of a drilling system: simulate, analyse stability, run rig operations, '
                'estimate the bit, record and replay.  `drill-twin COMMAND -h` for each '
                'command.', epilog='README.md and docs/ describe every command.')
    sub = p.add_subparsers(dest='command', required=True, title='commands', metavar='COMMAND')
    for package in PACKAGES:
        package.register(sub)
    return p


def _terminate(signum, frame):
    raise KeyboardInterrupt  # SIGTERM: unwind like Ctrl-C, so recordings get closed


#: what bad input raises: one line, exit code 2.  Anything else is a bug: its traceback
#: is shown and the exit code is 1.
USER_ERRORS = (ParameterError, SetpointError, SimulationDiverged, RecordingError, OSError)


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _terminate)
    try:
        return args.func(args)
    except BrokenPipeError:  # output piped into e.g. `head`, which closed it: not an error
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except USER_ERRORS as exc:
        print(f'drill-twin: error: {" ".join(str(exc).split())}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print('drill-twin: interrupted', file=sys.stderr)
        return 130


if __name__ == '__main__':
    sys.exit(main())

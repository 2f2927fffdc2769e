"""The hostile-input corpus: every case of ``test/data/hostile/*.yaml``, one parametrised
test.  Each case is a ``drill-twin`` command line (and the files it reads) that must end in
exit code 2 with one line on stderr naming what is wrong — the file, key or value — no
traceback, and nothing half-written.

A case (one item of a file's list)::

    - id: unknown-sweep-axis          # unique within the file
      argv: [sweep, --config, rgd_stick_slip, --x, 'nope.key:1:2:3', --out, '{tmp}/out']
      files: {bad.yaml: "units: si\\n"}   # written into the case's scratch directory first
                                         # (a value {base64: ...} gives bytes; {repeat:
                                         # [text, n]} gives text * n)
      env: {DASK_SCHEDULER_ADDRESS: bogus://}
      stderr: [nope.key, did you mean]   # must appear in the line (case-insensitive)
      absent: ['{tmp}/out']              # must not exist afterwards (nothing half-written)
      subprocess: true                   # run as a process (a case that could hang or
                                         # exhaust this one), with ``timeout`` seconds
      timeout: 60

``{tmp}`` in argv, env, files and absent is the case's scratch directory (also the
working directory); ``{http}`` is the address of an HTTP server on loopback (not a Dask
scheduler).
"""
import base64
import http.server
import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest
import yaml

from drill_twin.cli import main

#: a tier of its own: 442 command lines are not the numerics make test-fast is for
pytestmark = pytest.mark.inputs

CORPUS = Path(__file__).parent / 'data' / 'hostile'


def _cases():
    out = []
    for path in sorted(CORPUS.glob('*.yaml')):
        for case in yaml.safe_load(path.read_text()) or []:
            out.append(pytest.param(case, id=f'{path.stem}:{case["id"]}',
                                    marks=[pytest.mark.process] if case.get('subprocess')
                                    else []))
    return out


CASES = _cases()


def test_the_corpus_is_large_and_its_ids_unique():
    ids = [p.id for p in CASES]
    assert len(ids) == len(set(ids))
    assert len(ids) >= 200, len(ids)


@pytest.fixture(scope='module')
def http_address():
    """An HTTP server on loopback: a scheduler address where something else listens."""
    server = http.server.ThreadingHTTPServer(('127.0.0.1', 0),
                                             http.server.SimpleHTTPRequestHandler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f'tcp://127.0.0.1:{server.server_address[1]}'
    server.shutdown()


def _fill(value, tmp, http):
    if isinstance(value, str):
        return value.replace('{tmp}', str(tmp)).replace('{http}', http or '')
    if isinstance(value, list):
        return [_fill(v, tmp, http) for v in value]
    if isinstance(value, dict):
        return {k: _fill(v, tmp, http) for k, v in value.items()}
    return value


def _write(tmp: Path, name: str, content):
    path = tmp / name
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(content, dict) and 'base64' in content:
        path.write_bytes(base64.b64decode(content['base64']))
    elif isinstance(content, dict) and 'repeat' in content:
        text, n = content['repeat']
        path.write_text(str(text) * int(n))
    else:
        path.write_text(str(content))


@pytest.mark.parametrize('case', CASES)
def test_hostile_input_is_one_line_and_exit_code_2(case, tmp_path, monkeypatch, capsys,
                                                   request):
    http = request.getfixturevalue('http_address') if '{http}' in repr(case) else None
    case = _fill(case, tmp_path, http)
    for name, content in (case.get('files') or {}).items():
        _write(tmp_path, name, content)
    before = {p for p in tmp_path.rglob('*')}
    monkeypatch.chdir(tmp_path)
    if case.get('subprocess'):
        env = dict(os.environ, **{k: str(v) for k, v in (case.get('env') or {}).items()})
        proc = subprocess.run([sys.executable, '-m', 'drill_twin.cli', *case['argv']],
                              cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=case.get('timeout', 120))
        code, err = proc.returncode, proc.stderr
    else:
        for key, value in (case.get('env') or {}).items():
            monkeypatch.setenv(key, str(value))
        try:
            code = main([str(a) for a in case['argv']])
        except SystemExit as exc:          # argparse
            code = exc.code
        err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2, (code, lines[-5:])
    assert len(lines) == 1, lines[:5]
    assert 'Traceback' not in err
    for word in case.get('stderr') or []:
        assert str(word).lower() in lines[0].lower(), (word, lines[0])
    for path in case.get('absent') or []:
        assert not Path(path).exists(), f'{path} was left behind'
    made = {p for p in tmp_path.rglob('*')} - before
    leftovers = [p for p in made if p.suffix in ('.tmp', '.part') or p.name.endswith('.tmp')]
    assert not leftovers, leftovers

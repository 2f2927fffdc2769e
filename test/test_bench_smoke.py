"""The benchmark script runs end to end on tiny sizes (``make bench-smoke``; not part of
``make test``: it asserts nothing about speed, only that every part still produces its
rows, and takes about a minute)."""
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.bench
def test_bench_smoke():
    proc = subprocess.run([sys.executable, str(ROOT / 'bench' / 'run.py'), '--smoke'],
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    rows = [line for line in proc.stdout.splitlines()[1:] if line.strip()]
    sections = {line.split()[0] for line in rows}
    assert sections >= {'RTF', 'scaling', 'peers', 'stability', 'sweeps', 'nodes', 'realtime',
                        'memory', 'recording'}
    assert not any(' nan ' in f' {line} ' for line in rows), rows

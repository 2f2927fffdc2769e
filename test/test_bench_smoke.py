"""The benchmark script runs end to end on tiny sizes (asserts nothing about speed)."""
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_bench_smoke():
    proc = subprocess.run([sys.executable, str(ROOT / 'bench' / 'run.py'), '--smoke'],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    for section in ('RTF', 'scaling', 'peers', 'stability', 'nodes', 'memory'):
        assert f'\n{section} ' in proc.stdout

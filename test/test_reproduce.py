"""``drill-twin reproduce --quick``: every thesis figure of issue 8 at reduced resolution,
with the physics each one must show even in a short run."""
import json
import subprocess
import sys

import numpy as np
import pytest

from drill_twin.reproduce import FIGURE_IDS


@pytest.fixture(scope='module')
def quick_gallery(tmp_path_factory):
    out = tmp_path_factory.mktemp('gallery')
    proc = subprocess.run([sys.executable, '-m', 'drill_twin.cli', 'reproduce', '--quick',
                           '--out', str(out), '--progress'], capture_output=True, text=True,
                          timeout=900)
    assert proc.returncode == 0, proc.stderr
    assert '100%' in proc.stderr  # the progress bar ran to the end
    return out, json.loads((out / 'reproduction.json').read_text())


@pytest.mark.parametrize('fig_id', FIGURE_IDS)
def test_every_figure_is_drawn(quick_gallery, fig_id):
    out, summary = quick_gallery
    entry = summary[fig_id]
    png = (out / entry['png']).read_bytes()
    assert png[:8] == b'\x89PNG\r\n\x1a\n' and len(png) > 10_000
    assert entry['quick'] and entry['numbers']


def test_delay_residual_is_small(quick_gallery):
    """Fig. 3.3.4: eq. 2.4.14 holds along the run (thesis: |residual| < 5e-4)."""
    numbers = quick_gallery[1]['3.3.4']['numbers']
    assert all(v < 1e-8 for v in numbers.values())


def test_benchmark_sticks_axially_first(quick_gallery):
    """Fig. 3.3.2, phase (i): axial stick early (thesis: within the first tens of t*)."""
    numbers = quick_gallery[1]['3.3.2']['numbers']
    assert 5.0 < numbers['first_axial_stick_tau'] < 100.0


def test_root_path_crossings_are_at_multiples_of_pi(quick_gallery):
    """Fig. 4.2.4: roots cross the imaginary axis at Im z = qπ (delay 1: a crossing root
    satisfies e^{-iy} real for the 2-DOF chain with equal springs), q from 7 down to 1."""
    numbers = quick_gallery[1]['4.2.4']['numbers']
    for path in ('L1', 'L2'):
        q = np.array(numbers[f'{path} crossings Im/π'])
        assert np.all(np.abs(q - np.round(q)) < 0.2), q
        assert {7, 6, 5, 4, 3, 2, 1} <= set(np.round(q).astype(int))


def test_chain_phase_and_growth(quick_gallery):
    """Figs 4.2.5/4.3.2/4.4.1: in phase at (6.9, 2.96), out of phase at (3.45, 2.96); the
    growth rate equals the rightmost root of the linearisation (stability module)."""
    summary = quick_gallery[1]
    for fig_id in ('4.2.5', '4.3.2', '4.4.1'):
        inphase = summary[fig_id]['numbers']['(a, b) = (6.9, 2.96)']
        anti = summary[fig_id]['numbers']['(a, b) = (3.45, 2.96)']
        assert min(inphase['correlation_with_bit']) > 0.3
        assert min(anti['correlation_with_bit']) < -0.5
        for point in (inphase, anti):
            assert point['growth_rate_per_delay'] == pytest.approx(
                point['rightmost_root_real_part'], rel=0.3)  # 15 delays only: transients


def test_rgd2_locks_in_torsional_phase(quick_gallery):
    """Fig. 5.1.3: the two torsional oscillators move in phase; stick-slip with β = 0.3."""
    numbers = quick_gallery[1]['5.1.3']['numbers']
    assert numbers['torsional_correlation_second_half'] > 0.9
    assert numbers['first_angular_stick_tau'] is not None


def test_unknown_figure_is_a_clear_error(tmp_path):
    proc = subprocess.run([sys.executable, '-m', 'drill_twin.cli', 'reproduce', '--figure',
                           '9.9.9', '--out', str(tmp_path)], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 2 and 'unknown figure' in proc.stderr

"""The driller's log (issue 35): ``drill-twin mcap plot --log`` to PNG and to one
self-contained interactive HTML page holding every track."""
import json
import re

import pytest

pytest.importorskip('plotly')

from drill_twin.cli import main  # noqa: E402
from drill_twin.config.scenario import load_scenario  # noqa: E402
from drill_twin.drilling_log import TRACKS  # noqa: E402
from drill_twin.io.run_recorder import record_run  # noqa: E402


@pytest.fixture(scope='module')
def run(tmp_path_factory):
    path = tmp_path_factory.mktemp('log') / 'run.mcap'
    record_run(load_scenario('benchmark_fem'), path, 3.0, config='benchmark_fem')
    return path


def test_the_log_is_a_png_and_a_self_contained_html_page_with_every_track(run, capsys):
    assert main(['mcap', 'plot', str(run), '--log', '--json']) == 0
    out = json.loads(capsys.readouterr().out)
    assert out['samples'] == 300
    png, html = run.with_name('run_log.png'), run.with_name('run_log.html')
    assert out == {'png': str(png), 'html': str(html), 'samples': 300}
    assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n' and png.stat().st_size > 20_000
    page = html.read_text()
    # self-contained: Plotly's JavaScript inline, nothing fetched from elsewhere
    assert 'Plotly.newPlot' in page and len(page) > 1_000_000
    assert not re.search(r'<script[^>]+src=', page)
    assert not re.search(r'<link[^>]+href=["\']https?:', page)
    for title, curves in TRACKS:
        assert f'"text":"{title}"'.replace('/', '\\u002f') in page, title
        for _, label, _, _ in curves:
            assert f'"name":"{label}"' in page, label
    assert '"autorange":"reversed"' in page          # time runs down, as on a paper log


def test_a_depth_axis_and_one_format(run, tmp_path, capsys):
    out = tmp_path / 'log.html'
    assert main(['mcap', 'plot', str(run), '--log', '--depth', '--out', str(out),
                 '--json']) == 0
    written = json.loads(capsys.readouterr().out)
    assert set(written) == {'html', 'samples'}
    assert 'drilled depth [m]' in out.read_text()

"""ament_python package layout (checked against ros2/demos demo_nodes_py conventions)."""
import configparser
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_package_xml_is_format_3_ament_python():
    root = ET.parse(ROOT / 'package.xml').getroot()
    assert root.tag == 'package' and root.get('format') == '3'
    assert root.findtext('name') == 'drill_twin'
    for tag in ('version', 'description', 'maintainer', 'license'):
        assert root.findtext(tag)
    assert root.find('maintainer').get('email')
    deps = {e.text for e in root.findall('exec_depend')}
    assert {'rclpy', 'std_msgs', 'geometry_msgs', 'sensor_msgs', 'diagnostic_msgs',
            'rosgraph_msgs'} <= deps
    assert root.find('export').findtext('build_type') == 'ament_python'


def test_setup_cfg_script_dirs_and_resource_marker():
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / 'setup.cfg')
    assert cfg['develop']['script_dir'] == '$base/lib/drill_twin'
    assert cfg['install']['install_scripts'] == '$base/lib/drill_twin'
    assert (ROOT / 'resource' / 'drill_twin').is_file()
    setup = (ROOT / 'setup.py').read_text()
    for needle in ("'share/ament_index/resource_index/packages'", "'/config'", "'/launch'",
                   "'package.xml'"):
        assert needle in setup


def test_every_config_file_loads():
    from drill_twin.config.scenario import load_scenario
    files = sorted((ROOT / 'config').glob('*.yaml'))
    assert files
    for path in files:
        load_scenario(path)

"""rrps-record's command line: ``-o NAME`` names the bag folder itself, as ``ros2 bag record -o``
does, and a folder that exists is refused with one line and exit status 2, before anything starts."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from rrps_recording.record_cli import main, parser, ros_arguments
from rrps_testing.processes import interrupt


def _parameters(argv: list[str]) -> dict[str, str]:
    args = parser().parse_args(argv)
    out = ros_arguments(args)
    return dict(out[i + 1].split(':=', 1) for i in range(len(out) - 1) if out[i] == '-p')


def test_o_names_the_bag_folder():
    nested = _parameters(['-o', 'runs/today/session'])
    assert {'output_dir': 'runs/today', 'prefix': 'session'}.items() <= nested.items()
    assert {'output_dir': '.', 'prefix': 'session'}.items() <= _parameters(['-o', 'session']).items()
    flight = _parameters(['--flight-recorder-only', '-o', 'faults'])
    assert flight['output_dir'] == 'faults' and 'prefix' not in flight and flight['record'] == 'false'


@pytest.mark.parametrize('argv, says', [
    (['-o', '{existing}'], 'exists'),
    (['--buffer', '0'], '--buffer'),
    (['--flight-recorder-only', '--no-flight-recorder'], 'nothing to do'),
])
def test_bad_options_are_one_line_and_exit_2(tmp_path, capsys, argv, says):
    existing = tmp_path / 'session'
    existing.mkdir()
    (existing / 'keep').write_text('x')
    assert main([a.format(existing=existing) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and err.startswith('error:') and says in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ['session']
    assert [p.name for p in existing.iterdir()] == ['keep']


@pytest.mark.ros
@pytest.mark.slow
def test_a_recording_is_the_folder_o_names(tmp_path, ros_domain_id):
    """The command as a user runs it: the bag folder appears at exactly -o's path, with
    rosbag2's metadata.yaml (its relative_file_paths inside it) once Ctrl-C stops it."""
    bag = tmp_path / 'runs' / 'session'
    env = {**os.environ, 'ROS_DOMAIN_ID': str(ros_domain_id)}
    process = subprocess.Popen([sys.executable, '-m', 'rrps_recording.record_cli', '-o', str(bag),
                                '--namespace', f'/rrps_{os.getpid()}', '--no-flight-recorder'],
                               env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not any(bag.glob('*.mcap')) and process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.2)
    finally:
        interrupt(process)
    assert process.returncode == 0, process.stderr.read()[-2000:]
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['relative_file_paths'] and all((bag / f).is_file() for f in info['relative_file_paths'])
    assert [p.name for p in (tmp_path / 'runs').iterdir()] == ['session']
    assert main(['-o', str(bag)]) == 2   # a second recording to the same name is refused
    assert Path(bag / 'metadata.yaml').is_file()

"""The package layers of .importlinter hold (import-linter), they fail when broken, no module in
src/ is longer than 400 lines and no test module longer than 500."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / 'src'
LINT_IMPORTS = Path(sys.executable).parent / 'lint-imports'
TESTS = ROOT / 'tests'
MAX_LINES = 400
MAX_TEST_LINES = 500


def _lint_imports(pythonpath: list[Path] | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    if pythonpath:
        env['PYTHONPATH'] = os.pathsep.join(map(str, pythonpath))
    return subprocess.run([str(LINT_IMPORTS), '--config', str(ROOT / '.importlinter'), '--no-cache'],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)


def test_every_layer_contract_is_kept():
    out = _lint_imports()
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-2000:]
    assert 'Contracts: 5 kept, 0 broken.' in out.stdout


@pytest.mark.parametrize('module, line, broken', [
    ('rrps_kinematics/inverse.py', 'import rclpy', 'Pure cores import no ROS'),
    ('rrps_description/pose.py', 'from std_msgs.msg import Header', 'The description and the interfaces are pure'),
    ('rrps_kinematics/forward.py', 'import rrps_teleop.mapping', 'Packages import only the packages below them'),
    ('rrps_runtime/qos.py', 'import rrps_loads.statics', 'Packages import only the packages below them'),
    ('rrps_hardware/interface.py', 'import rrps_sim.actuators', 'Packages import only the packages below them'),
    ('rrps_canopen/robot.py', 'import rrps_sim.actuators', 'The CANopen hardware and teleoperation do not import'),
    ('rrps_canopen/drive.py', 'import rrps_canopen_sim.drive', 'The CANopen hardware and teleoperation do not'),
    ('rrps_teleop/load_guard.py', 'import rrps_sim.preview', 'The CANopen hardware and teleoperation do not import'),
    ('rrps_climbing/gait.py', 'import rclpy', 'Pure cores import no ROS'),
    ('rrps_kinematics/limits.py', 'import rrps_runtime.freshness', 'The kinematics core does not import the runtime'),
])
def test_a_broken_layer_fails_the_check(tmp_path, module, line, broken):
    """A copy of src/ with one forbidden import added, checked in place of the installed one."""
    package = module.split('/')[0]
    paths = []
    for source in sorted(SRC.glob('rrps_*')):
        target = tmp_path / source.name
        shutil.copytree(source / source.name, target / source.name,
                        ignore=shutil.ignore_patterns('__pycache__'))
        paths.append(target)
    path = tmp_path / package / package / Path(*module.split('/')[1:])
    path.write_text(path.read_text() + f'\n{line}  # noqa\n')
    out = _lint_imports(paths)
    assert out.returncode != 0, out.stdout[-3000:]
    assert f'{broken}' in out.stdout and 'BROKEN' in out.stdout, out.stdout[-3000:]


def _longer_than(root: Path, limit: int) -> dict[str, int]:
    """The Python modules under ``root`` (not in build trees or node_modules) over ``limit`` lines."""
    return {str(p.relative_to(root)): n for p in root.rglob('*.py')
            if not {'build', 'node_modules'} & set(p.relative_to(root).parts)
            and (n := len(p.read_text().splitlines())) > limit}


def test_no_module_in_src_is_longer_than_400_lines():
    assert not _longer_than(SRC, MAX_LINES)


def test_no_test_module_is_longer_than_500_lines():
    assert not _longer_than(TESTS, MAX_TEST_LINES)

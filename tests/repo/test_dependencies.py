"""Each package in src/ declares exactly what it imports, for pip and for rosdep.

Every package with a ``setup.py`` in ``src/`` (found, not listed: the check follows a split of
the packages) is compared with its imports by deptry (pinned in requirements.txt): an import its
``install_requires`` does not declare, or a declaration it never imports, fails. A dependency used
at run time without an import (a node started by name, a library's plug-in) is declared in the
``USED_WITHOUT_IMPORT`` list of its setup.py, and only there. Its ``package.xml`` declares the
same dependencies as ROS keys: the rrps packages and ROS packages by name (a ``ros-jazzy-NAME``
wheel is the ROS package ``NAME``), the other Python packages by their rosdep key
(:data:`ROSDEP_KEYS`); the interface packages built here from source (``tools/tf2_msgs``) are in
``package.xml`` only, since PyPI has no wheel of them. requirements.txt pins every distribution
the packages declare. The checks are shown failing on an undeclared import, an unused
declaration and a package.xml that disagrees.
"""

from __future__ import annotations

import contextlib
import json
import re
import runpy
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass, replace
from pathlib import Path
from unittest import mock

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / 'src'
ROS_WHEEL_PREFIX = 'ros-jazzy-'
#: The rosdep key of each Python distribution the packages declare (normalised name -> key):
#: rosdistro's keys (rosdep/python.yaml, read at rosdistro commit 8468e88c), or where rosdistro
#: has none this repository's rosdep.yaml (a rosdep source: docs/architecture.md, "Packages").
ROSDEP_KEYS = {
    'canopen': 'canopen-pip',
    'foxglove-sdk': 'python3-foxglove-sdk-pip',
    'matplotlib': 'python3-matplotlib',
    'mcap': 'python3-mcap-pip',
    'msgpack': 'python3-msgpack',
    'msgspec': 'python3-msgspec-pip',
    'numba': 'python3-numba',
    'numpy': 'python3-numpy',
    'pytest': 'python3-pytest',
    'python-can': 'python3-can',
    'pyyaml': 'python3-yaml',
    'rosbags': 'python3-rosbags-pip',
    'ruckig': 'python3-ruckig-pip',
    'scipy': 'python3-scipy',
    'toppra': 'python3-toppra-pip',
    'viser': 'python3-viser-pip',
    'zstandard': 'python3-zstandard-pip',
}


def normalise(name: str) -> str:
    """A distribution's name as PEP 503 compares them."""
    return re.sub(r'[-_.]+', '-', name).lower()


def bare(requirement: str) -> str:
    """A requirement's distribution, without its extras (``ros-jazzy-rclpy[fastrtps]``: the RMW
    implementation rclpy loads, a run-time dependency of every package that imports rclpy)."""
    return requirement.split('[')[0]


def packages() -> list[str]:
    return sorted(p.parent.name for p in SRC.glob('*/setup.py'))


def interface_packages() -> set[str]:
    """ROS interface packages built from source here (an ament_cmake package.xml in tools/ or src/)."""
    found = set()
    for xml in [*ROOT.glob('tools/*/package.xml'), *SRC.glob('*/package.xml')]:
        root = ET.parse(xml).getroot()
        if root.findtext('export/build_type') == 'ament_cmake':
            found.add(root.findtext('name'))
    return found


@dataclass(frozen=True)
class Declared:
    """What one package declares: setup.py's install_requires (and, of them, the ones used without
    an import) and package.xml's exec_depend keys."""

    name: str
    requires: tuple[str, ...]
    used_without_import: tuple[str, ...]
    exec_depends: tuple[str, ...]


def declared(name: str) -> Declared:
    """Run the package's setup.py with ``setuptools.setup`` replaced, to read its arguments."""
    directory = SRC / name
    with mock.patch('setuptools.setup') as setup, contextlib.chdir(directory):
        namespace = runpy.run_path(str(directory / 'setup.py'))
    requires = tuple(setup.call_args.kwargs.get('install_requires', ()))
    root = ET.parse(directory / 'package.xml').getroot()
    depends = tuple(e.text.strip() for tag in ('depend', 'exec_depend') for e in root.iter(tag))
    return Declared(name, requires, tuple(namespace.get('USED_WITHOUT_IMPORT', ())), depends)


def _module_of(distribution: str) -> str | None:
    """The module a ROS distribution provides, where deptry cannot read it from installed metadata."""
    if distribution.startswith(ROS_WHEEL_PREFIX):
        return distribution.removeprefix(ROS_WHEEL_PREFIX).replace('-', '_')
    return distribution if distribution in interface_packages() else None


def deptry_issues(directory: Path, name: str, requires: list[str], tmp_path: Path,
                  ignore_unused: tuple[str, ...] = ()) -> list[str]:
    """deptry's findings ('DEP001 module file:line', ...) for the package in ``directory``
    declaring ``requires``."""
    requirements = tmp_path / f'{name}-requirements.txt'
    requirements.write_text(''.join(f'{r}\n' for r in requires))
    report = tmp_path / f'{name}-deptry.json'
    names = ','.join(f'{bare(r)}={module}' for r in requires if (module := _module_of(bare(r))))
    command = [sys.executable, '-m', 'deptry', '.', '--no-ansi', '--known-first-party', name,
               '--requirements-files', str(requirements), '--json-output', str(report)]
    command += ['--package-module-name-map', names] if names else []
    command += ['--per-rule-ignores', 'DEP002=' + '|'.join(ignore_unused)] if ignore_unused else []
    out = subprocess.run(command, cwd=directory, capture_output=True, text=True, timeout=120)
    assert report.exists(), out.stdout[-2000:] + out.stderr[-2000:]
    return [f"{i['error']['code']} {i['module']} {Path(i['location']['file']).name}:{i['location']['line'] or ''}"
            for i in json.loads(report.read_text())]


def rosdep_key(requirement: str) -> str:
    requirement = bare(requirement)
    if requirement.startswith('rrps_'):
        return requirement
    if requirement.startswith(ROS_WHEEL_PREFIX):
        return requirement.removeprefix(ROS_WHEEL_PREFIX).replace('-', '_')
    key = ROSDEP_KEYS.get(normalise(requirement))
    assert key, f'no rosdep key known for {requirement}: add it to ROSDEP_KEYS (rosdistro\'s, or one in rosdep.yaml)'
    return key


def package_xml_disagreements(d: Declared) -> dict[str, list[str]]:
    """The keys package.xml lacks and the ones it has beyond setup.py's (interface packages built
    here belong to package.xml alone)."""
    expected = {rosdep_key(r) for r in d.requires}
    have = set(d.exec_depends) - interface_packages()
    return {k: v for k, v in (('missing', sorted(expected - have)), ('extra', sorted(have - expected))) if v}


def pins() -> dict[str, str]:
    found = {}
    for line in (ROOT / 'requirements.txt').read_text().splitlines():
        if (m := re.fullmatch(r'([A-Za-z0-9_.-]+)==(\S+)', line.split('#')[0].strip())):
            found[normalise(m.group(1))] = m.group(2)
    return found


def _check_requires(d: Declared) -> list[str]:
    """setup.py and package.xml's source-built interfaces: the dependency list deptry checks."""
    return [*d.requires, *sorted(set(d.exec_depends) & interface_packages())]


@pytest.mark.parametrize('name', packages())
def test_each_package_imports_what_it_declares_and_declares_what_it_imports(name, tmp_path):
    d = declared(name)
    issues = deptry_issues(SRC / name, name, _check_requires(d), tmp_path, d.used_without_import)
    assert not issues, (f'{name}: DEP001/DEP003: imported, not declared in setup.py; DEP002: declared, '
                        f'never imported (or list it in USED_WITHOUT_IMPORT with the reason)\n' + '\n'.join(issues))


@pytest.mark.parametrize('name', packages())
def test_what_is_used_without_import_is_really_not_imported(name, tmp_path):
    """A USED_WITHOUT_IMPORT entry the package does import is a stale exception."""
    d = declared(name)
    assert set(d.used_without_import) <= set(d.requires), 'USED_WITHOUT_IMPORT must be in install_requires'
    unused = {issue.split()[1] for issue in deptry_issues(SRC / name, name, _check_requires(d), tmp_path)
              if issue.startswith('DEP002')}
    assert unused == set(d.used_without_import)


@pytest.mark.parametrize('name', packages())
def test_package_xml_declares_the_same_dependencies_as_rosdep_keys(name):
    d = declared(name)
    assert not package_xml_disagreements(d), package_xml_disagreements(d)
    assert len(d.exec_depends) == len(set(d.exec_depends)), 'a key is declared twice'


def test_requirements_pin_every_declared_distribution():
    pinned = pins()
    unpinned = {f'{d.name}: {r}' for d in map(declared, packages()) for r in d.requires
                if not r.startswith('rrps_') and normalise(bare(r)) not in pinned}
    assert not unpinned, f'pin these in requirements.txt: {sorted(unpinned)}'


def test_every_rosdep_key_is_used_and_the_repository_keys_install_their_package():
    used = {rosdep_key(r) for d in map(declared, packages()) for r in d.requires}
    assert set(ROSDEP_KEYS.values()) <= used, f'stale ROSDEP_KEYS: {set(ROSDEP_KEYS.values()) - used}'
    ours = yaml.safe_load((ROOT / 'rosdep.yaml').read_text())
    assert set(ours) <= used, f'stale keys in rosdep.yaml: {set(ours) - used}'
    for distribution, key in ROSDEP_KEYS.items():
        if key in ours:
            for platform in ('debian', 'ubuntu'):
                assert [normalise(p) for p in ours[key][platform]['pip']['packages']] == [distribution], key
    assert not {k for k in ours if not k.endswith('-pip')}, 'a pip-installed rosdep key ends in -pip'


# The checks fail when they should: an injected import, a dropped or a surplus declaration.

def test_an_undeclared_import_fails(tmp_path):
    d = declared('rrps_description')
    copy = tmp_path / 'rrps_description'
    shutil.copytree(SRC / 'rrps_description', copy, ignore=shutil.ignore_patterns('__pycache__', '*.egg-info'))
    pose = copy / 'rrps_description' / 'pose.py'
    pose.write_text(pose.read_text() + '\nimport viser  # noqa\n')
    issues = deptry_issues(copy, d.name, _check_requires(d), tmp_path)
    assert any(i.split()[:2] in (['DEP001', 'viser'], ['DEP003', 'viser']) and 'pose.py' in i for i in issues), issues


def test_a_dropped_or_a_surplus_declaration_fails(tmp_path):
    d = declared('rrps_kinematics')
    assert 'scipy' in d.requires and 'viser' not in d.requires
    dropped = [r for r in _check_requires(d) if r != 'scipy']
    assert any(i.split()[:2] in (['DEP001', 'scipy'], ['DEP003', 'scipy'])
               for i in deptry_issues(SRC / d.name, d.name, dropped, tmp_path))
    surplus = [*_check_requires(d), 'viser', 'ros-jazzy-visualization-msgs']
    issues = deptry_issues(SRC / d.name, d.name, surplus, tmp_path)
    assert {i.split()[1] for i in issues if i.startswith('DEP002')} == {'viser', 'ros-jazzy-visualization-msgs'}, issues


def test_a_package_xml_that_disagrees_fails():
    d = declared('rrps_teleop')
    assert package_xml_disagreements(replace(d, exec_depends=d.exec_depends[1:])) == {'missing': [d.exec_depends[0]]}
    extra = replace(d, exec_depends=(*d.exec_depends, 'trajectory_msgs'))
    assert package_xml_disagreements(extra) == {'extra': ['trajectory_msgs']}

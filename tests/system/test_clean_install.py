"""Each package installs on its own, with the dependencies it declares, into a clean environment.

For every package of src/ (found by its setup.py, so the test follows a split of the packages):
its wheel, and the wheels of the rrps packages it declares, are installed with their declared
dependencies into a fresh venv (no system site-packages, none of this checkout's environment)
from the wheelhouse that ``./rrps install`` downloaded once (``--no-index``: the pinned PyPI
wheels, the ROS 2 Jazzy ones among them). The installer is uv's ``uv pip install``, which reads
the same metadata as pip and links the wheels from its cache: 0.7 s a venv where pip took 15 s.
Then every module of the package imports there, and each of its command-line tools
(``rrps-*``), loaded from its entry point, answers ``--help``: in that same interpreter, so each
package pays one interpreter start (the tools' own executables start from the colcon install
tree in tests/system/test_install_tree.py). A dependency the package imports but does not declare fails
here as an ImportError (tests/repo/test_dependencies.py finds it without installing).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from importlib.metadata import distribution
from pathlib import Path

import pytest

from rrps_testing.ci import require

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / 'src'
PACKAGES = sorted(p.parent.name for p in SRC.glob('*/setup.py'))
#: Where ./rrps install keeps the wheels of requirements.txt.
WHEELHOUSE = Path(sys.prefix) / 'wheelhouse'

pytestmark = pytest.mark.slow

#: Imports every module of the package named by argv[1], then runs each of its ``rrps-*``
#: console scripts (loaded from the entry point) with ``--help``; prints what it did.
IMPORT_ALL = '''
import contextlib, importlib, io, pkgutil, sys
from importlib.metadata import distribution
package = importlib.import_module(sys.argv[1])
names = [m.name for m in pkgutil.walk_packages(package.__path__, package.__name__ + '.')]
for name in names:
    importlib.import_module(name)
print(len(names), 'modules of', package.__file__)
tools = sorted((ep for ep in distribution(sys.argv[1]).entry_points
                if ep.group == 'console_scripts' and ep.name.startswith('rrps-')), key=lambda ep: ep.name)
for ep in tools:
    sys.argv = [ep.name, '--help']
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        try:
            ep.load()()
            code = 0
        except SystemExit as exit:
            code = exit.code or 0
    if code != 0 or 'usage' not in out.getvalue().lower():
        sys.exit(f'{ep.name} --help: exit {code}: {out.getvalue()[-2000:]}')
print('tools:', ' '.join(ep.name for ep in tools))
'''


#: [s] A guard against a hang (it times nothing): building the wheels or installing them runs at
#: nice 10 beside the system tests, and under ``./rrps test --load`` a slow hour made a build that
#: takes minutes pass 600 s.
COMMAND_TIMEOUT = 1800


def _run(command: list[str], env: dict | None = None, timeout: float = COMMAND_TIMEOUT) -> subprocess.CompletedProcess:
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout, env=env, cwd='/')


@pytest.fixture(scope='module')
def uv_cache(tmp_path_factory) -> Path:
    """uv's cache, shared by this module's venvs (one unpacking of each wheel)."""
    return tmp_path_factory.mktemp('uv-cache')


@pytest.fixture(scope='module')
def package_wheels(tmp_path_factory) -> Path:
    """Every package's wheel, built from a copy of its source (src/ stays clean)."""
    require(WHEELHOUSE.is_dir(), f'no wheelhouse at {WHEELHOUSE}: ./rrps install makes it')
    base = tmp_path_factory.mktemp('packages')
    for name in PACKAGES:
        shutil.copytree(SRC / name, base / 'src' / name,
                        ignore=shutil.ignore_patterns('*.egg-info', '__pycache__', 'build'))
    out = _run([sys.executable, '-m', 'pip', 'wheel', '-q', '--no-index', '--no-deps', '--no-build-isolation',
                '-w', str(base / 'wheels'), *(str(base / 'src' / name) for name in PACKAGES)])
    assert out.returncode == 0, out.stderr[-3000:]
    return base / 'wheels'


@pytest.fixture(scope='module')
def install_dir(tmp_path_factory) -> Path:
    """Where each test makes its fresh venv (``venv``, removed first) and where the venvs' byte code
    is kept (``pycache``, PYTHONPYCACHEPREFIX): the same path each time, so the modules a venv
    imports are compiled to byte code once for the module, not once per package."""
    return tmp_path_factory.mktemp('clean-install')


def _clean_environment(venv: Path) -> dict[str, str]:
    """What a user's shell would have in that venv: none of this checkout's variables (its venv,
    library path, ament prefix); byte code beside the venv (:func:`install_dir`). numba imports but
    compiles nothing (``NUMBA_DISABLE_JIT``: the kernels stay plain Python, rrps_kinematics.backend):
    importing is what is checked here, and compiling the eager kernels at import took most of the
    module's time; the suite runs the compiled kernels in the checkout's venv."""
    return {'PATH': f'{venv / "bin"}:/usr/bin:/bin', 'HOME': os.environ.get('HOME', '/tmp'), 'LANG': 'C.UTF-8',
            'PYTHONPYCACHEPREFIX': str(venv.parent / 'pycache'), 'NUMBA_DISABLE_JIT': '1',
            'VIRTUAL_ENV': str(venv), 'AMENT_PREFIX_PATH': str(venv), 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
            'RRPS_TEST_SESSION': os.environ.get('RRPS_TEST_SESSION', '')}


@pytest.mark.parametrize('name', PACKAGES)
def test_the_package_installs_alone_imports_and_starts(name, package_wheels, uv_cache, install_dir):
    venv = install_dir / 'venv'
    shutil.rmtree(venv, ignore_errors=True)
    assert _run([sys.executable, '-m', 'venv', '--without-pip', str(venv)]).returncode == 0
    python = str(venv / 'bin' / 'python')
    uv = shutil.which('uv') or str(Path(sys.executable).parent / 'uv')
    require(Path(uv).exists(), 'uv is not installed (requirements.txt pins it)')
    out = _run([uv, 'pip', 'install', '-q', '--offline', '--no-index', '--python', python,
                '--find-links', str(WHEELHOUSE), '--find-links', str(package_wheels),
                '-c', str(ROOT / 'requirements.txt'), name],
               env={**os.environ, 'UV_CACHE_DIR': str(uv_cache), 'UV_NO_CONFIG': '1'})
    assert out.returncode == 0, f'pip install {name} with its declared dependencies:\n{out.stderr[-3000:]}'
    env = _clean_environment(venv)
    installed = _run([python, '-c', 'import sys; print(sys.path)'], env).stdout
    assert str(ROOT) not in installed and '.venv' not in installed, installed
    out = _run([python, '-c', IMPORT_ALL, name], env, timeout=300)
    assert out.returncode == 0, f'{name} does not import with its declared dependencies:\n{out.stderr[-3000:]}'
    assert f'{venv}' in out.stdout, out.stdout   # the installed package, not the source
    tools = sorted(ep.name for ep in distribution(name).entry_points
                   if ep.group == 'console_scripts' and ep.name.startswith('rrps-'))
    assert f"tools: {' '.join(tools)}" in out.stdout, out.stdout  # each answered --help

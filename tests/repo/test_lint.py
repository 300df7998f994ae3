"""The code base lints clean: pyflakes, pycodestyle, import order and complexity (ruff.toml)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

from rrps_testing.ci import require

ROOT = Path(__file__).resolve().parents[2]


def test_ruff_finds_nothing_in_src_tests_and_benchmarks():
    ruff = shutil.which('ruff', path=str(Path(sys.executable).parent)) or shutil.which('ruff')
    require(ruff is not None, 'ruff is not installed (requirements.txt pins it)')
    result = subprocess.run([ruff, 'check', '--no-cache', 'src', 'tests', 'benchmarks'], cwd=ROOT,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr


def test_no_benchmark_script_shadows_a_module_it_runs_beside():
    """A script puts its folder first on sys.path: a benchmark named like an installed module (a
    ``canopen.py``) would be imported in its place by every benchmark run as a script."""
    import importlib.util
    clashes = [p.name for p in (ROOT / 'benchmarks').glob('*.py') if importlib.util.find_spec(p.stem) is not None]
    assert not clashes, clashes

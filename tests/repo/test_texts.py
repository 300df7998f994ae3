"""What users read refers to nothing they do not have: no internal issue numbers and no paths
outside the repository, in code, tests, benchmarks, docs or the README."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FOLDERS = ('src', 'tests', 'benchmarks', 'docs', 'docker', 'tools')
SUFFIXES = {'.py', '.md', '.yaml', '.yml', '.xml', '.cfg', '.toml', '.sh', '.js', '.json', ''}
ISSUE = re.compile(r'\bissues? ?#?\d+\b', re.IGNORECASE)
OUTSIDE = re.compile(r'\.\./shared\b')


def _texts():
    yield ROOT / 'README.md'
    for folder in FOLDERS:
        for path in (ROOT / folder).rglob('*'):
            if (path.is_file() and path.suffix in SUFFIXES and 'node_modules' not in path.parts
                    and '.egg-info' not in str(path) and '__pycache__' not in path.parts):
                yield path


def test_no_internal_issue_numbers_or_paths_outside_the_repository():
    found = []
    for path in _texts():
        try:
            text = path.read_text(encoding='utf-8')
        except UnicodeDecodeError:
            continue
        for number, line in enumerate(text.splitlines(), 1):
            if ISSUE.search(line) or OUTSIDE.search(line):
                found.append(f'{path.relative_to(ROOT)}:{number}: {line.strip()[:100]}')
    assert not found, '\n'.join(found)

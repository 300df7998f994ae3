"""Every relative link of the README and of docs/*.md points at a file that exists, and every
anchor of a link into a Markdown file names one of its headings (GitHub's heading ids)."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: [text](target) and ![alt](target), the text possibly over several lines; an optional title.
LINK = re.compile(r'!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+"[^"]*")?\s*\)')
FENCE = re.compile(r'^(```|~~~).*?^\1[^\n]*$', re.MULTILINE | re.DOTALL)
CODE_SPAN = re.compile(r'`[^`\n]*`')
HEADING = re.compile(r'^#{1,6}\s+(.+?)\s*#*\s*$', re.MULTILINE)
EXTERNAL = re.compile(r'^[a-z][a-z0-9+.-]*:', re.IGNORECASE)


def documents(root: Path = ROOT) -> list[Path]:
    return [root / 'README.md', *sorted((root / 'docs').glob('*.md'))]


def _prose(text: str) -> str:
    """The Markdown without its code blocks and code spans (their brackets are not links)."""
    return CODE_SPAN.sub('', FENCE.sub('', text))


def heading_ids(text: str) -> set[str]:
    """GitHub's ids of a document's headings: lower case, punctuation dropped, spaces as hyphens,
    a repeated id numbered -1, -2, ..."""
    ids: set[str] = set()
    for heading in HEADING.findall(FENCE.sub('', text)):
        plain = re.sub(r'!?\[([^\]]*)\]\([^)]*\)', r'\1', heading).replace('`', '')
        base = re.sub(r'[^\w\- ]', '', plain.lower()).replace(' ', '-')
        slug, n = base, 0
        while slug in ids:
            n += 1
            slug = f'{base}-{n}'
        ids.add(slug)
    return ids


def broken_links(paths: list[Path], root: Path = ROOT) -> list[str]:
    """'<document>: <target> (why)' for every relative link that does not resolve."""
    found = []
    for path in paths:
        for target in LINK.findall(_prose(path.read_text(encoding='utf-8'))):
            if EXTERNAL.match(target):
                continue
            file_part, _, anchor = target.partition('#')
            where = f'{path.relative_to(root)}: {target}'
            resolved = (path.parent / file_part).resolve() if file_part else path
            if not resolved.exists():
                found.append(f'{where} (no such file)')
            elif root.resolve() not in resolved.parents and resolved != root.resolve():
                found.append(f'{where} (outside the repository)')
            elif anchor and resolved.suffix == '.md' and anchor not in heading_ids(resolved.read_text()):
                found.append(f'{where} (no such heading)')
    return found


def test_every_relative_link_of_the_docs_resolves():
    assert not broken_links(documents()), '\n'.join(broken_links(documents()))


def test_the_check_finds_a_missing_file_an_outside_path_and_a_missing_heading(tmp_path):
    root = tmp_path / 'repo'
    (root / 'docs').mkdir(parents=True)
    (root / 'docs' / 'guide.md').write_text('# Guide\n\n## Two words\n\n```\n[not](a-link.md)\n```\n')
    (tmp_path / 'outside.md').write_text('# Outside\n')
    (root / 'README.md').write_text(
        'See [the guide](docs/guide.md#two-words), [`code`](docs/guide.md), '
        '[the web](https://example.org/x.md) and [here](#top).\n\n# Top\n\n'
        '[gone](docs/missing.md), ![picture\nover two lines](docs/missing.png), '
        '[far](../outside.md), [no heading](docs/guide.md#three-words)\n')
    found = broken_links(documents(root), root)
    assert found == ['README.md: docs/missing.md (no such file)',
                     'README.md: docs/missing.png (no such file)',
                     'README.md: ../outside.md (outside the repository)',
                     'README.md: docs/guide.md#three-words (no such heading)'], found


def test_heading_ids_follow_github():
    text = '# Markers and /tf\n## The MCAP files: ros2 profile\n## `rrps_description` (pure)\n## Step\n## Step\n'
    assert heading_ids(text) == {'markers-and-tf', 'the-mcap-files-ros2-profile', 'rrps_description-pure',
                                 'step', 'step-1'}

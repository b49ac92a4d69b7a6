"""Docstrings cite only what the repository holds: published works through docs/references.md,
no notes or issues kept elsewhere."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCES = sorted([*(ROOT / 'hand_tracker_ros').rglob('*.py'), *(ROOT / 'bench').glob('*.py')])
WORKS = re.compile(r'Ballan|Tkach|Tagliasacchi|htrack|hmodel|HOPE|Oikonomidis|Kroeger|Clerc|'
                   r'levmar|Amanatides|second seed')
ELSEWHERE = re.compile(r'perf-notes|\bissue \d+|\bseed brief')


def test_no_citation_of_documents_outside_the_repository() -> None:
    offenders = [p.relative_to(ROOT).as_posix() for p in SOURCES
                 if ELSEWHERE.search(p.read_text())]
    assert offenders == []


def test_modules_citing_published_works_point_at_the_references() -> None:
    assert (ROOT / 'docs' / 'references.md').is_file()
    offenders = [p.relative_to(ROOT).as_posix() for p in SOURCES
                 if WORKS.search(p.read_text()) and 'docs/references.md' not in p.read_text()]
    assert offenders == []

"""The energy-term table is the one list of terms: the config, the presets and the README
follow it."""
from __future__ import annotations

import dataclasses
import re
import typing
from pathlib import Path

from hand_tracker_ros.energies import registry
from hand_tracker_ros.evaluation import presets

README = Path(__file__).resolve().parents[2] / 'README.md'


def test_terms_config_has_one_field_per_row_in_table_order() -> None:
    hints = typing.get_type_hints(registry.TermsConfig)
    fields = [f.name for f in dataclasses.fields(registry.TermsConfig)]
    assert fields == list(registry.NAMES)
    assert [hints[n] for n in fields] == [t.config for t in registry.TERMS]


def test_names_are_unique_and_each_class_names_itself() -> None:
    assert len(set(registry.NAMES)) == len(registry.NAMES)
    assert all(t.energy.name == t.name for t in registry.TERMS)


def test_ablation_rows() -> None:
    assert set(presets.ABLATION['LO+E']) == {'edges', 'temporal'}
    assert set(presets.ABLATION['LO+EC']) == {'edges', 'collision', 'volume', 'temporal'}
    assert set(presets.ABLATION['LO+ECO']) == {'edges', 'collision', 'volume', 'flow', 'temporal'}
    assert set(presets.ABLATION['LO+ECOS']) == {'edges', 'collision', 'volume', 'flow',
                                                'salient', 'temporal'}
    assert presets.ABLATION['full'] == registry.NAMES
    assert registry.SEPARATION_TERMS == ('collision', 'volume')


def test_readme_term_table_lists_the_registry() -> None:
    rows = re.findall(r'^\| (\S+) `(\w+)` \|', README.read_text(), re.M)
    assert [(name, key) for key, name in rows] == [(t.name, t.key) for t in registry.TERMS]

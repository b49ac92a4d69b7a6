"""Config dataclasses: mapping round trips, validation messages, shipped YAML files."""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml

from hand_tracker_ros import node_config
from hand_tracker_ros.ament import share_file
from hand_tracker_ros.cli.params import default_parameters_yaml
from hand_tracker_ros.config import describe, flatten, from_mapping, nested, overrides, param
from hand_tracker_ros.errors import ConfigError
from hand_tracker_ros.graph_nodes import NODES


@dataclass(frozen=True)
class Inner:
    max_iterations: int = param(10, 'LM iterations', low=1, high=100)
    method: str = param('dis', 'flow method', choices=('dis', 'lk'))


@dataclass(frozen=True)
class Outer:
    weight: float = param(1.0, 'term weight', low=0.0)
    names: tuple[str, ...] = param(('a', 'b'), 'names')
    lm: Inner = nested(Inner)


def test_dotted_and_nested_mappings_agree() -> None:
    a = from_mapping(Outer, {'lm.max_iterations': 5, 'weight': 2})
    b = from_mapping(Outer, {'lm': {'max_iterations': 5}, 'weight': 2.0})
    assert a == b
    assert a.weight == 2.0 and isinstance(a.weight, float)
    assert flatten(a) == {'weight': 2.0, 'names': ('a', 'b'), 'lm.max_iterations': 5,
                          'lm.method': 'dis'}


@pytest.mark.parametrize(('mapping', 'message'), [
    ({'lm.max_iterations': 0}, r'`lm.max_iterations` must be in \[1, 100\], got 0'),
    ({'lm.method': 'farneback'}, r"`lm.method` must be one of \['dis', 'lk'\]"),
    ({'weight': 'heavy'}, r'`weight` must be a number'),
    ({'lm.max_iterations': 2.5}, r'`lm.max_iterations` must be an integer'),
    ({'names': 'abc'}, r'`names` must be a list'),
    ({'wieght': 1.0}, r'unknown parameter\(s\) wieght'),
    ({'weight': float('nan')}, r'`weight` must be a finite number'),
])
def test_bad_values_name_the_field(mapping: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        from_mapping(Outer, mapping)


def test_command_line_overrides_are_dotted_keys_with_yaml_values() -> None:
    parsed = overrides(['a.b=1', 'c=true', 'd=[1, 2]', 'e=x=y'])
    assert parsed == {'a.b': 1, 'c': True, 'd': [1, 2], 'e': 'x=y'}
    with pytest.raises(ConfigError, match="override 'a.b': expected KEY=VALUE"):
        overrides(['a.b'])
    with pytest.raises(ConfigError, match='is not YAML'):
        overrides(['a=[1'])


def test_a_number_in_exponent_form_without_a_dot_is_a_number() -> None:
    # YAML 1.1 (PyYAML) reads 1e-3 as a string; YAML 1.2 and every user read a number.
    assert from_mapping(Outer, overrides(['weight=1e-3'])).weight == 0.001
    assert from_mapping(Outer, {'weight': '+2E+2'}).weight == 200.0
    with pytest.raises(ConfigError, match='`weight` must be a number'):
        from_mapping(Outer, {'weight': 'nan'})
    with pytest.raises(ConfigError, match='`lm.max_iterations` must be an integer'):
        from_mapping(Outer, {'lm.max_iterations': '1e1'})


def test_describe_carries_docs_and_ranges() -> None:
    meta = describe(Outer)
    assert meta['lm.max_iterations']['low'] == 1
    assert meta['weight']['doc'] == 'term weight'


@pytest.mark.parametrize(('node', 'cls'), node_config.NODE_CONFIGS.items())
def test_shipped_parameter_files_match_the_config_classes(node: str, cls: type) -> None:
    text = share_file(f'config/{node}.yaml').read_text()
    assert text == default_parameters_yaml(node)
    params = yaml.safe_load(text)[node]['ros__parameters']
    assert from_mapping(cls, params) == cls()


def test_readme_node_table_lists_the_graph_nodes() -> None:
    readme = (Path(__file__).resolve().parents[1] / 'README.md').read_text()
    table = readme.split('| executable | subscribes |', 1)[1].split('\n\n', 1)[0]
    assert tuple(re.findall(r'^\| `(\w+)` \|', table, re.M)) == NODES


def test_every_node_has_an_entry_point_and_a_parameter_file() -> None:
    root = Path(__file__).resolve().parents[1]
    assert all((root / 'hand_tracker_ros' / 'nodes' / f'{n}_node.py').is_file() for n in NODES)
    assert all((root / 'config' / f'{n}.yaml').is_file() for n in NODES)

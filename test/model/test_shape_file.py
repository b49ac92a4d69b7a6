"""Hand shape files: exact round trip, partial files, clear errors."""
from __future__ import annotations

from pathlib import Path

import pytest

from hand_tracker_ros.errors import ConfigError
from hand_tracker_ros.model.shape import HandShape
from hand_tracker_ros.model.shape_file import FORMAT, load_shape, save_shape, shape_or_default


def test_round_trip_is_exact(tmp_path: Path) -> None:
    shape = HandShape(scale=1.0731, palm_width_m=0.0577, index_m=(0.0511, 0.02901, 0.0193),
                      radius_scale=0.93)
    save_shape(shape, tmp_path / 's.yaml', comment='fitted by a test\nsecond line')
    text = (tmp_path / 's.yaml').read_text()
    assert text.startswith('# fitted by a test\n# second line\nformat: ')
    assert load_shape(tmp_path / 's.yaml') == shape


def test_missing_fields_keep_the_default(tmp_path: Path) -> None:
    (tmp_path / 's.yaml').write_text(f'format: {FORMAT}\nscale: 1.1\n')
    assert load_shape(tmp_path / 's.yaml') == HandShape(scale=1.1)
    assert shape_or_default('') == HandShape()


@pytest.mark.parametrize(('body', 'match'), [
    ('scale: 1.1\n', '`format` must be'),
    (f'format: {FORMAT}\nscael: 1.1\n', r'unknown key\(s\) scael'),
    (f'format: {FORMAT}\nscale: big\n', '`scale` must be a number'),
    (f'format: {FORMAT}\nthumb_m: [0.04, 0.03]\n', '`thumb_m` must be a list of 3'),
    (f'format: {FORMAT}\npalm_width_m: -0.05\n', 'finite and > 0: palm_width_m'),
    ('- 1\n- 2\n', 'must be a YAML mapping'),
    ('scale: [1\n', 'not valid YAML'),
])
def test_invalid_files_name_the_file_and_field(tmp_path: Path, body: str, match: str) -> None:
    path = tmp_path / 'bad.yaml'
    path.write_text(body)
    with pytest.raises(ConfigError, match=match) as err:
        load_shape(path)
    assert str(path) in str(err.value)


def test_missing_file_is_a_config_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match='does not exist'):
        load_shape(tmp_path / 'none.yaml')

"""Status codes have one source, HandState.msg: the enum, the generated message and the
README follow it."""
from __future__ import annotations

import re
from pathlib import Path

from hand_tracker_ros.status import TrackStatus

ROOT = Path(__file__).resolve().parents[1]
MSG = ROOT / 'msg_defs' / 'hand_tracker_msgs' / 'msg' / 'HandState.msg'


def _msg_constants() -> dict[str, int]:
    found = re.findall(r'^uint8 STATUS_(\w+)=(\d+)\s*$', MSG.read_text(), re.M)
    return {name: int(value) for name, value in found}


def test_enum_equals_the_message_definition() -> None:
    assert _msg_constants() == {s.name: s.value for s in TrackStatus}


def test_enum_equals_the_generated_message_class() -> None:
    from hand_tracker_msgs.msg import HandState

    assert {s.name: getattr(HandState, f'STATUS_{s.name}') for s in TrackStatus} == \
        {s.name: s.value for s in TrackStatus}


def test_readme_names_every_status() -> None:
    names = ' / '.join(s.name.lower() for s in TrackStatus)
    assert f'({names})' in (ROOT / 'README.md').read_text()

"""House rule 1: the core never imports ROS; only nodes/ and ros_io/ may."""
from __future__ import annotations

import ast
import importlib.util
import subprocess
import sys
from pathlib import Path

import hand_tracker_ros

PACKAGE_DIR = Path(hand_tracker_ros.__file__).parent
ROS_MODULES = ('rclpy', 'rcl_interfaces', 'sensor_msgs', 'std_msgs', 'geometry_msgs',
               'visualization_msgs', 'diagnostic_msgs', 'rosgraph_msgs', 'builtin_interfaces',
               'hand_tracker_msgs', 'tf2_msgs', 'cv_bridge', 'message_filters',
               'ament_index_python')
ADAPTERS = ('nodes', 'ros_io')
# Core modules that need an optional package (requirements/train.txt), imported only when it
# is installed.
OPTIONAL = {'hand_tracker_ros.vision.detector.network': 'torch'}


def _core_modules() -> list[str]:
    names = []
    for path in sorted(PACKAGE_DIR.rglob('*.py')):
        rel = path.relative_to(PACKAGE_DIR.parent).with_suffix('')
        if rel.parts[1] in ADAPTERS:
            continue
        name = '.'.join(rel.parts).removesuffix('.__init__')
        if name in OPTIONAL and importlib.util.find_spec(OPTIONAL[name]) is None:
            continue
        names.append(name)
    return names


def test_core_imports_with_ros_blocked() -> None:
    block = '; '.join(f'sys.modules[{m!r}] = None' for m in ROS_MODULES)
    imports = '; '.join(f'import {m}' for m in _core_modules())
    result = subprocess.run([sys.executable, '-c', f'import sys; {block}; {imports}'],
                            capture_output=True, text=True, timeout=240)
    assert result.returncode == 0, result.stderr


def test_no_core_file_mentions_ros_imports() -> None:
    offenders = []
    for path in PACKAGE_DIR.rglob('*.py'):
        if path.relative_to(PACKAGE_DIR).parts[0] in ADAPTERS:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module or ''] if isinstance(node, ast.ImportFrom) else [])
            offenders += [f'{path.name}: {n}' for n in names if n.split('.')[0] in ROS_MODULES]
    assert not offenders


def test_package_init_is_empty() -> None:
    assert (PACKAGE_DIR / '__init__.py').read_text().strip() == ''

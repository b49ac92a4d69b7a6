"""Find installed package resources the way `ros2 run` does, without importing ROS.

`ros2 run PKG EXE` looks the package prefix up in the ament resource index (a marker file
``share/ament_index/resource_index/packages/PKG`` under one of the prefixes listed in
``AMENT_PREFIX_PATH``) and runs the executable file named EXE under ``<prefix>/lib/PKG/``.
The launcher and the tests use the same lookup, so what works here works with ``ros2 run``.
"""
from __future__ import annotations

import os
from pathlib import Path

from hand_tracker_ros.errors import HandTrackerError

PACKAGE = 'hand_tracker_ros'
_SOURCE_ROOT = Path(__file__).resolve().parents[1]


def package_prefix(package: str = PACKAGE) -> Path:
    """Install prefix of ``package`` from ``AMENT_PREFIX_PATH`` (first match wins)."""
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if prefix and (Path(prefix) / 'share/ament_index/resource_index/packages' / package
                       ).is_file():
            return Path(prefix)
    msg = f"package '{package}' not found in AMENT_PREFIX_PATH (source .ws/env.sh first)"
    raise HandTrackerError(msg)


def executable(name: str, package: str = PACKAGE) -> Path:
    """Path of executable ``name`` under ``<prefix>/lib/<package>/`` (what `ros2 run` runs)."""
    root = package_prefix(package) / 'lib' / package
    hits = []
    for folder, dirs, files in os.walk(root):
        dirs[:] = [d for d in dirs if not d.startswith('.')]  # as ros2run does
        hits += [Path(folder) / f for f in files
                 if f == name and os.access(Path(folder) / f, os.X_OK)]
    if len(hits) != 1:
        msg = f"{'no' if not hits else 'several'} executable '{name}' in {root}"
        raise HandTrackerError(msg)
    return hits[0]


def share_file(relative: str, package: str = PACKAGE) -> Path:
    """A file under ``share/<package>/`` of the install tree, or of the source tree.

    The source tree wins when it has the file, so a checkout without a build still works.
    """
    source = _SOURCE_ROOT / relative
    if source.exists():
        return source
    installed = package_prefix(package) / 'share' / package / relative
    if installed.exists():
        return installed
    msg = f'{relative} not found in {_SOURCE_ROOT} nor in the install tree of {package}'
    raise HandTrackerError(msg)

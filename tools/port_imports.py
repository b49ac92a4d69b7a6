"""Rewrite imports of the paths the seams branch moved (issue 20), for branches made before it.

Usage: ``python tools/port_imports.py $(git ls-files '*.py' '*.md')``, then
``ruff check --fix .`` to sort the imports again. Rewrites ``from hand_tracker_ros.X import a, b``
statements (splitting them when the names went to different modules) and dotted mentions in
docstrings; prints each file it changed. Names that were removed rather than moved are listed
in ``REMOVED`` and reported, not rewritten.
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

PKG = 'hand_tracker_ros.'
MODULE_MOVES = {   # whole modules
    'tracking.result': 'core.result',
    'energies.base': 'core.energy',
    'tracking.energies': 'energies.registry',
    'vision.image_codec': 'bags.image_codec',
}
NAME_MOVES = {     # (old module, name) -> new module; checked before MODULE_MOVES
    ('tracking.observations', 'SalientDetections'): 'vision.detections',
    ('tracking.observations', 'CameraObservation'): 'core.observations',
    ('tracking.observations', 'FrameObservations'): 'core.observations',
    ('tracking.views', 'ModelView'): 'core.views',
    ('tracking.views', 'model_views'): 'core.views',
    ('tracking.views', 'PreviousFrame'): 'core.context',
    ('tracking.views', 'RoundContext'): 'core.context',
    ('tracking.result', 'TrackStatus'): 'status',
    ('tracking.problem', 'Term'): 'core.energy',
    ('pipeline.frames', 'FrameSet'): 'core.frames',
    ('energies.collision', 'CollisionPairs'): 'core.context',
    ('vision.image', 'check_rgb'): 'checks',
    ('vision.image', 'check_image_size'): 'checks',
    ('synthetic.motions', 'RELAXED_DEG'): 'model.poses',
    ('cli.launch', 'NODES'): 'graph_nodes',
}
REMOVED = {
    'tracking.separation.COLLISION_TERMS': 'energies.registry.SEPARATION_TERMS',
    'synthetic.writer.STATUS_TRACKING': 'int(status.TrackStatus.TRACKING)',
    'model.hand._NEUTRAL': 'model.poses.NEUTRAL_RAD',
    'cli.demo.GRAPH': 'graph_nodes.NODES',
    'evaluation.presets.TERMS': 'energies.registry.NAMES',
}
IMPORT = re.compile(r'^(?P<indent>[ \t]*)from hand_tracker_ros\.(?P<mod>[\w.]+) import '
                    r'(?P<names>\([^)]*\)|[^\n]*)', re.M)


def _new_module(module: str, name: str) -> str:
    if (module, name) in NAME_MOVES:
        return NAME_MOVES[module, name]
    return MODULE_MOVES.get(module, module)


def _statement(match: re.Match[str]) -> str:
    raw = match['names'].strip()
    if '#' in raw:
        return match.group(0)
    names = [n.strip() for n in raw.strip('()').replace('\n', ' ').split(',') if n.strip()]
    groups: dict[str, list[str]] = {}
    for name in names:
        groups.setdefault(_new_module(match['mod'], name.split(' as ')[0]), []).append(name)
    if list(groups) == [match['mod']]:
        return match.group(0)
    return '\n'.join(f'{match["indent"]}from {PKG}{module} import {", ".join(group)}'
                     for module, group in groups.items())


def port(text: str) -> str:
    """``text`` with the moved imports and dotted mentions rewritten."""
    text = IMPORT.sub(_statement, text)
    for (old, name), new in NAME_MOVES.items():
        text = text.replace(f'{PKG}{old}.{name}', f'{PKG}{new}.{name}')
    for old, new in MODULE_MOVES.items():
        text = text.replace(PKG + old, PKG + new)
        text = text.replace(f'hand_tracker_ros/{old.replace(".", "/")}.py',
                            f'hand_tracker_ros/{new.replace(".", "/")}.py')
    return text


def main(paths: list[str]) -> int:
    for path in map(Path, paths):
        text = path.read_text()
        new = port(text)
        if new != text:
            path.write_text(new)
            print(f'ported {path}')
        for old, replacement in REMOVED.items():
            if old.rsplit('.', 1)[1] in new and old.rsplit('.', 1)[0] in new:
                print(f'{path}: uses {old}? now {replacement}')
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))

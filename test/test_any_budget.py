"""Issue 20: ``Any`` only where values are truly dynamic.

Counts ``Any`` in the annotations of function signatures (parameters and returns) and of
class-level attributes (dataclass fields) in the algorithm packages.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

import hand_tracker_ros

PACKAGE_DIR = Path(hand_tracker_ros.__file__).parent
PACKAGES = ('energies', 'tracking', 'optim', 'model', 'pipeline')
BUDGET = 5
_ANY = re.compile(r'\bAny\b')


def _signature_annotations(tree: ast.AST) -> list[ast.expr]:
    annotations: list[ast.expr | None] = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            args = node.args
            annotations += [a.annotation for a in args.posonlyargs + args.args + args.kwonlyargs]
            annotations += [a.annotation for a in (args.vararg, args.kwarg) if a is not None]
            annotations.append(node.returns)
        elif isinstance(node, ast.ClassDef):
            annotations += [s.annotation for s in node.body if isinstance(s, ast.AnnAssign)]
    return [a for a in annotations if a is not None]


def any_in_signatures(packages: tuple[str, ...] = PACKAGES) -> dict[str, int]:
    """``{path: count}`` of ``Any`` in the signature annotations of ``packages``."""
    counts = {}
    for package in packages:
        for path in sorted((PACKAGE_DIR / package).rglob('*.py')):
            tree = ast.parse(path.read_text())
            n = sum(len(_ANY.findall(ast.unparse(a))) for a in _signature_annotations(tree))
            if n:
                counts[str(path.relative_to(PACKAGE_DIR))] = n
    return counts


def test_any_in_signatures_within_budget() -> None:
    counts = any_in_signatures()
    assert sum(counts.values()) <= BUDGET, counts


def test_counter_sees_any() -> None:
    tree = ast.parse('def f(x: Any, *a: tuple[Any, ...]) -> dict[str, Any]: ...\n'
                     'class C:\n    y: Any\n    z = 1\n')
    assert sum(len(_ANY.findall(ast.unparse(a))) for a in _signature_annotations(tree)) == 4

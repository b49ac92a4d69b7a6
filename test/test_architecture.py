"""docs/architecture.md, enforced: the import-linter contracts hold and no package of
hand_tracker_ros imports, directly or through others, a package that imports it back."""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

grimp = pytest.importorskip('grimp', reason='grimp comes with import-linter '
                                                   '(requirements/dev.txt)')

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = 'hand_tracker_ros'


def _package_graph() -> dict[str, set[str]]:
    """Top-level subpackages and modules of the package -> those they import directly."""
    graph = grimp.build_graph(PACKAGE, include_external_packages=False)
    tops = sorted(m for m in graph.modules if m.count('.') == 1)
    return {a: {b for b in tops if b != a and graph.direct_import_exists(
        importer=a, imported=b, as_packages=True)} for a in tops}


def package_cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one package (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    cycles: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return cycles


def test_no_package_level_import_cycle() -> None:
    assert package_cycles(_package_graph()) == []


def test_cycle_finder_finds_a_cycle() -> None:
    assert package_cycles({'a': {'b'}, 'b': {'c'}, 'c': {'a'}, 'd': {'a'}}) == [['a', 'b', 'c']]


def test_import_contracts_are_kept() -> None:
    exe = shutil.which('lint-imports') or str(Path(sys.executable).parent / 'lint-imports')
    if not Path(exe).exists():
        pytest.skip('import-linter is not installed (requirements/dev.txt)')
    result = subprocess.run([exe, str(ROOT / '.importlinter'), '--no-cache'], cwd=ROOT,
                            capture_output=True, text=True, timeout=240)
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'broken' in result.stdout and ' 0 broken' in result.stdout

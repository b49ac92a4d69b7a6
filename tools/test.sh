#!/usr/bin/env bash
# Set everything up (idempotent), lint with ruff, type-check the core with mypy and run the test
# suite. Extra arguments go to pytest.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$ROOT/tools/setup.sh"
# shellcheck disable=SC1091
. "$ROOT/.ws/env.sh"
cd "$ROOT"
# Lint and type-check first (ruff.toml, mypy.ini: the core packages of docs/architecture.md):
# either fails CI before any test runs.
ruff check --quiet .
mypy
exec python -m pytest "$@"

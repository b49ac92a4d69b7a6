#!/usr/bin/env bash
# Set everything up (idempotent), lint with ruff, type-check with mypy and run the test suite.
# Extra arguments go to pytest.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$ROOT/tools/setup.sh"
# shellcheck disable=SC1091
. "$ROOT/.ws/env.sh"
cd "$ROOT"
# Lint and type-check first (ruff.toml; mypy.ini, which says what it checks): either
# fails CI before any test runs.
ruff check --quiet .
mypy
exec python -m pytest "$@"

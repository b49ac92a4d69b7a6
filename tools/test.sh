#!/usr/bin/env bash
# Set everything up (idempotent), lint with ruff and run the test suite. Extra arguments go to
# pytest.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$ROOT/tools/setup.sh"
# shellcheck disable=SC1091
. "$ROOT/.ws/env.sh"
cd "$ROOT"
# Lint first (ruff.toml): a lint error fails CI before any test runs.
ruff check --quiet .
exec python -m pytest "$@"

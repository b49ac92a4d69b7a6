#!/usr/bin/env bash
# Set everything up (idempotent) and run the demo on the built-in synthetic data.
# Extra arguments go to `hand-tracker demo`.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$ROOT/tools/setup.sh"
# shellcheck disable=SC1091
. "$ROOT/.ws/env.sh"
cd "$ROOT"
exec hand-tracker demo "$@"

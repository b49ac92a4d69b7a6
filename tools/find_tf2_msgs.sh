#!/usr/bin/env bash
# Print the install prefix of an installed tf2_msgs (a full ROS install on AMENT_PREFIX_PATH,
# or the venv), or nothing. Prefixes inside the workspace WS (our own build of
# msg_defs/tf2_msgs) do not count. Usage: find_tf2_msgs.sh VENV WS
set -euo pipefail
venv=$1 ws=$2
for prefix in "$venv" ${AMENT_PREFIX_PATH:+${AMENT_PREFIX_PATH//:/ }}; do
  case "$prefix" in "$ws"/*) continue ;; esac
  if [ -e "$prefix/share/ament_index/resource_index/packages/tf2_msgs" ]; then
    echo "$prefix"
    exit 0
  fi
done

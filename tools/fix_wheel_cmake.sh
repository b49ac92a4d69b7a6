#!/bin/sh
# Rewrite the build-container paths baked into the ROS wheels' exported CMake files.
#
# The manylinux image that built the ros-* wheels left /opt/python/cpXY-cpXY/... include paths
# in share/**/*Export.cmake; CMake then refuses to generate ("Imported target ... includes
# non-existent path"). We point them at this venv's Python and numpy include directories.
# Idempotent: a second run finds nothing to rewrite.
# usage: fix_wheel_cmake.sh VENV_PREFIX
set -eu
V="${1:?usage: fix_wheel_cmake.sh VENV_PREFIX}"
PYINC=$("$V/bin/python" -c "import sysconfig; print(sysconfig.get_paths()['include'])")
NPINC=$("$V/bin/python" -c "import numpy; print(numpy.get_include())")
PYVER=$("$V/bin/python" -c "import sys; print('%d.%d' % sys.version_info[:2])")
TAG=cp$(echo "$PYVER" | tr -d .)
grep -rl "/opt/python/$TAG-$TAG" "$V/share" --include='*.cmake' 2>/dev/null | xargs -r sed -i \
  -e "s#/opt/python/$TAG-$TAG/include/python$PYVER#$PYINC#g" \
  -e "s#/opt/python/$TAG-$TAG/lib/python$PYVER/site-packages/numpy/_core/include#$NPINC#g"
left=$(grep -rl "/opt/python/$TAG-$TAG" "$V/share" --include='*.cmake' 2>/dev/null | wc -l)
if [ "$left" -ne 0 ]; then
  echo "fix_wheel_cmake: $left CMake files still reference /opt/python" >&2
  exit 1
fi

#!/usr/bin/env bash
# Create .venv and install the pinned dependencies and the workspace packages.
# Idempotent: re-runs only when requirements.lock or a package's setup.py changed.
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON="${PYTHON:-python3}"
VENV=.venv
STAMP="$VENV/.setup-stamp"

"$PYTHON" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else 1)' || {
  echo "setup: Python 3.11 or newer is required (found $("$PYTHON" --version 2>&1))" >&2; exit 1; }

if [ ! -x "$VENV/bin/python" ]; then
  if ! "$PYTHON" -m venv "$VENV" 2>/dev/null; then
    # Debian/Ubuntu ship venv separately.
    echo "setup: python venv module missing; installing python3-venv" >&2
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get update -q && $SUDO apt-get install -y -q python3-venv
    rm -rf "$VENV"; "$PYTHON" -m venv "$VENV"
  fi
fi

# tf2_msgs (the message of /tf and /tf_static) has no PyPI wheel: build it from its definition in src/tf2_msgs
# with the rosidl generators into .venv, once per change of its sources or of the pinned packages.
# src/tf2_msgs carries COLCON_IGNORE, so on a full ROS 2 install colcon leaves the system tf2_msgs alone.
build_tf2_msgs() {
  local want_tf stamp_tf="$VENV/.tf2_msgs-stamp" build="$VENV/build/tf2_msgs" prefix
  want_tf=$(cat requirements.lock src/tf2_msgs/CMakeLists.txt src/tf2_msgs/package.xml src/tf2_msgs/msg/*.msg \
            | sha256sum | cut -d' ' -f1)
  if [ -f "$stamp_tf" ] && [ "$(cat "$stamp_tf")" = "$want_tf" ]; then return 0; fi
  if ! command -v cmake >/dev/null || ! command -v c++ >/dev/null || ! command -v make >/dev/null; then
    echo "setup: cmake and a C/C++ compiler are needed to build tf2_msgs; installing cmake g++ make" >&2
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get update -q && $SUDO apt-get install -y -q cmake g++ make
  fi
  echo "setup: building tf2_msgs from src/tf2_msgs into $VENV"
  prefix="$(cd "$VENV" && pwd)"
  rm -rf "$build"; mkdir -p "$build"
  {
    AMENT_PREFIX_PATH="$prefix" CMAKE_PREFIX_PATH="$prefix" LD_LIBRARY_PATH="$prefix/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" \
      PATH="$prefix/bin:$PATH" \
      sh -c 'cmake -S src/tf2_msgs -B "$1" -DCMAKE_INSTALL_PREFIX="$2" -DPython3_EXECUTABLE="$2/bin/python" \
               -DBUILD_TESTING=OFF -DCMAKE_BUILD_TYPE=Release \
             && cmake --build "$1" -j 2 && cmake --install "$1"' _ "$build" "$prefix"
  } >"$VENV/tf2_msgs-build.log" 2>&1 || { tail -40 "$VENV/tf2_msgs-build.log" >&2;
      echo "setup: building tf2_msgs failed (log: $VENV/tf2_msgs-build.log)" >&2; exit 1; }
  "$VENV/bin/python" -c 'from tf2_msgs.msg import TFMessage' \
    || { echo "setup: tf2_msgs was built but does not import" >&2; exit 1; }
  echo "$want_tf" > "$stamp_tf"
}

# Numba kernels (cache=True) are cached in __pycache__ beside their source: compile them here, once per change of
# the kernels' sources, the warm-up or the pinned packages, so a new user's first replay does not spend a minute
# compiling.
warm_numba() {
  local want_nb stamp_nb="$VENV/.numba-stamp"
  want_nb=$(cat requirements.lock scripts/warm_numba.py $(grep -rl --include='*.py' numba src) \
            | sha256sum | cut -d' ' -f1)
  if [ -f "$stamp_nb" ] && [ "$(cat "$stamp_nb")" = "$want_nb" ] \
     && ls src/ins_gps_kf/ins_gps_kf/__pycache__/*.nbi >/dev/null 2>&1; then return 0; fi
  echo "setup: compiling the numba kernels into their cache (a minute on 2 cores, once)"
  "$VENV/bin/python" scripts/warm_numba.py || { echo "setup: compiling the numba kernels failed" >&2; exit 1; }
  echo "$want_nb" > "$stamp_nb"
}

want=$(cat requirements.lock src/*/setup.py src/*/package.xml | sha256sum | cut -d' ' -f1)
if [ -f "$STAMP" ] && [ "$(cat "$STAMP")" = "$want" ]; then build_tf2_msgs; warm_numba; exit 0; fi

echo "setup: installing pinned dependencies into $VENV (first run takes a few minutes)"
"$VENV/bin/python" -m pip install -q --upgrade pip >"$VENV/setup.log" 2>&1
"$VENV/bin/python" -m pip install -q -r requirements.lock >>"$VENV/setup.log" 2>&1 || { cat "$VENV/setup.log" >&2; exit 1; }
for pkg in src/*/; do
  [ -f "$pkg/setup.py" ] || continue  # src/tf2_msgs is a CMake package, built below
  "$VENV/bin/python" -m pip install -q --no-deps --no-build-isolation -e "$pkg" >>"$VENV/setup.log" 2>&1 || { cat "$VENV/setup.log" >&2; exit 1; }
done
build_tf2_msgs
warm_numba
echo "$want" > "$STAMP"
echo "setup: done"

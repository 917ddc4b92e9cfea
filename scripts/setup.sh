#!/usr/bin/env bash
# RVWO set-up: installs every build and test dependency on Debian 12 (bookworm).
#
#   bash scripts/setup.sh            # as root, or as a user with sudo
#
# 1. Debian packages (Eigen, OpenCV, MRPT, Ceres, SuiteSparse, GoogleTest, Google Benchmark, ...).
# 2. ONNX Runtime 1.21 unless the system has one: the shared library from the PyPI wheel
#    onnxruntime==1.21.1, the matching C/C++ headers from Debian 13's libonnxruntime-dev 1.21.0
#    (fetched with a private apt configuration whose source is this system's own Debian mirror,
#    suite swapped to trixie; nothing is installed system-wide from Debian 13).
# 3. g2o unless the system has one: the static C++ libraries, headers and CMake config that the
#    PyPI wheel g2opy==2.3.0 carries.
# 4. A Python environment for rvwo-bag (ROS bags without ROS): the rosbags package and its
#    dependencies, pinned in scripts/python-requirements.txt, from PyPI wheels.
# Steps 2 to 4 unpack into .deps/ (git-ignored; override with RVWO_DEPS_DIR). Idempotent: a
# second run with nothing missing only checks. A failing step prints one line naming it and
# exits non-zero; its full output is kept in .deps/setup.log.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
DEPS=${RVWO_DEPS_DIR:-$ROOT/.deps}
LOG=$DEPS/setup.log
ORT_WHEEL_VERSION=1.21.1
ORT_DEB_VERSION=1.21.0+dfsg-1
G2OPY_VERSION=2.3.0
DEBIAN_PACKAGES=(build-essential cmake ninja-build pkg-config git python3 python3-pip python3-venv
  libeigen3-dev libopencv-dev libmrpt-dev libceres-dev libsuitesparse-dev
  libgtest-dev libgmock-dev libbenchmark-dev nlohmann-json3-dev zlib1g-dev clang-format clang libclang-rt-14-dev)

mkdir -p "$DEPS"
: >"$LOG"
say() { printf 'setup: %s\n' "$*"; }
fail() { printf 'setup: FAILED: %s (details: %s)\n' "$*" "$LOG" >&2; exit 1; }
# run WHAT CMD...: run CMD with its output in the log; on failure one line naming WHAT.
run() { local what=$1; shift; echo "+ $*" >>"$LOG"; "$@" >>"$LOG" 2>&1 || fail "$what"; }

if [ "$(id -u)" -eq 0 ]; then SUDO=(); elif command -v sudo >/dev/null; then SUDO=(sudo); else
  fail "not root and no sudo: run as root to install Debian packages"; fi

# ---- 1. Debian packages -------------------------------------------------------------------
missing=()
for p in "${DEBIAN_PACKAGES[@]}"; do
  dpkg-query -W -f='${db:Status-Status}' "$p" 2>/dev/null | grep -qx installed || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  say "installing Debian packages: ${missing[*]}"
  run "apt-get update" "${SUDO[@]}" apt-get update
  run "apt-get install ${missing[*]}" "${SUDO[@]}" env DEBIAN_FRONTEND=noninteractive \
    apt-get install -y --no-install-recommends "${missing[@]}"
else
  say "Debian packages: all ${#DEBIAN_PACKAGES[@]} present"
fi

case "$(uname -m)" in
  x86_64) WHEEL_PLATFORM=manylinux_2_28_x86_64 ;;
  aarch64) WHEEL_PLATFORM=manylinux_2_28_aarch64 ;;
  *) fail "no ONNX Runtime / g2o wheels for architecture $(uname -m)" ;;
esac
# pip_fetch WHAT SPEC DIR: download one wheel (no dependencies) for CPython 3.11 on this platform.
pip_fetch() {
  run "download of $2 from PyPI" python3 -m pip download --no-deps --only-binary=:all: \
    --python-version 3.11 --platform "$WHEEL_PLATFORM" --disable-pip-version-check \
    --retries "${RVWO_PIP_RETRIES:-3}" --timeout 30 -d "$3" "$2"
}
unzip_py() { python3 -c 'import sys, zipfile; zipfile.ZipFile(sys.argv[1]).extractall(sys.argv[2])' "$1" "$2"; }

# ---- 2. ONNX Runtime ----------------------------------------------------------------------
ORT=$DEPS/onnxruntime
if [ -f /usr/include/onnxruntime/onnxruntime_cxx_api.h ] && ls /usr/lib/*/libonnxruntime.so >/dev/null 2>&1; then
  say "ONNX Runtime: using the system's"
elif [ -f "$ORT/.complete-$ORT_WHEEL_VERSION" ]; then
  say "ONNX Runtime $ORT_WHEEL_VERSION: present in $ORT"
else
  say "ONNX Runtime $ORT_WHEEL_VERSION: fetching library (PyPI wheel) and headers (Debian 13 package)"
  tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
  pip_fetch ort "onnxruntime==$ORT_WHEEL_VERSION" "$tmp/whl"
  run "unpacking the onnxruntime wheel" unzip_py "$tmp"/whl/onnxruntime-*.whl "$tmp/ort"
  # Private apt configuration: this system's own Debian mirror, suite trixie, nothing else.
  src=$(cat /etc/apt/sources.list /etc/apt/sources.list.d/*.list 2>/dev/null |
    awk '$1=="deb" && $0 ~ / bookworm / {for(i=2;i<=NF;i++) if ($i ~ /^[a-z]+:\/\//) {print $i; exit}}' || true)
  [ -n "$src" ] || src=$(cat /etc/apt/sources.list.d/*.sources 2>/dev/null |
    awk '/^URIs:/{u=$2} /^Suites:/{ if ($0 ~ /[ \t]bookworm([ \t]|$)/) {print u; exit} }' || true)
  [ -n "$src" ] || fail "no Debian bookworm mirror found in /etc/apt/sources.list*"
  apt=$tmp/apt; mkdir -p "$apt"/{lists/partial,cache/archives/partial,parts,prefs}; : >"$apt/status"
  echo "deb [signed-by=/usr/share/keyrings/debian-archive-keyring.gpg] $src trixie main" >"$apt/sources.list"
  cat >"$apt/apt.conf" <<CONF
Dir::State "$apt"; Dir::State::Lists "$apt/lists"; Dir::State::status "$apt/status";
Dir::Cache "$apt/cache"; Dir::Etc::SourceList "$apt/sources.list"; Dir::Etc::SourceParts "$apt/parts";
Dir::Etc::Preferences "$apt/prefs/none"; Dir::Etc::PreferencesParts "$apt/prefs";
APT::Sandbox::User "root"; Acquire::Languages "none";
Acquire::IndexTargets::deb::DEP-11::DefaultEnabled "false";
Acquire::IndexTargets::deb::DEP-11-icons::DefaultEnabled "false";
Acquire::IndexTargets::deb::DEP-11-icons-small::DefaultEnabled "false";
Acquire::IndexTargets::deb::CNF::DefaultEnabled "false";
CONF
  run "apt-get update of the private trixie source ($src)" env APT_CONFIG="$apt/apt.conf" apt-get update
  run "download of libonnxruntime-dev=$ORT_DEB_VERSION (Debian 13)" \
    bash -c "cd '$tmp' && APT_CONFIG='$apt/apt.conf' apt-get download 'libonnxruntime-dev=$ORT_DEB_VERSION'"
  run "unpacking libonnxruntime-dev" dpkg-deb -x "$tmp"/libonnxruntime-dev_*.deb "$tmp/deb"
  rm -rf "$ORT"; mkdir -p "$ORT/lib" "$ORT/include"
  cp -r "$tmp/deb/usr/include/onnxruntime" "$ORT/include/"
  cp "$tmp/ort/onnxruntime/capi/libonnxruntime.so.$ORT_WHEEL_VERSION" "$ORT/lib/"
  ln -sf "libonnxruntime.so.$ORT_WHEEL_VERSION" "$ORT/lib/libonnxruntime.so.1"
  ln -sf "libonnxruntime.so.1" "$ORT/lib/libonnxruntime.so"
  touch "$ORT/.complete-$ORT_WHEEL_VERSION"
  rm -rf "$tmp"; trap - EXIT
fi

# ---- 3. g2o -------------------------------------------------------------------------------
G2O=$DEPS/g2o
if ls /usr/lib/cmake/g2o/g2oConfig.cmake /usr/local/lib/cmake/g2o/g2oConfig.cmake \
     /usr/lib/*/cmake/g2o/g2oConfig.cmake >/dev/null 2>&1; then
  say "g2o: using the system's"
elif [ -f "$G2O/.complete-$G2OPY_VERSION" ]; then
  say "g2o (g2opy $G2OPY_VERSION): present in $G2O"
else
  say "g2o: fetching static libraries from the g2opy $G2OPY_VERSION wheel"
  tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
  pip_fetch g2o "g2opy==$G2OPY_VERSION" "$tmp/whl"
  rm -rf "$G2O"; mkdir -p "$G2O"
  run "unpacking the g2opy wheel" unzip_py "$tmp"/whl/g2opy-*.whl "$tmp/g2o"
  cp -r "$tmp/g2o/include" "$tmp/g2o/lib" "$tmp/g2o/lib64" "$G2O/"
  touch "$G2O/.complete-$G2OPY_VERSION"
  rm -rf "$tmp"; trap - EXIT
fi
# ---- 4. Python environment (rvwo-bag) ------------------------------------------------------
PY=$DEPS/python
requirements=$ROOT/scripts/python-requirements.txt
pinned=$(sha256sum "$requirements" | cut -c1-16)  # a new pin list makes a new environment
if [ -f "$PY/.complete-$pinned" ]; then
  say "Python environment (rosbags): present in $PY"
else
  say "Python environment: rosbags and its dependencies, pinned (scripts/python-requirements.txt), into $PY"
  rm -rf "$PY"
  run "creating the Python environment $PY" python3 -m venv "$PY"
  run "install of scripts/python-requirements.txt from PyPI" "$PY/bin/python" -m pip install --no-deps \
    --only-binary=:all: --disable-pip-version-check --retries "${RVWO_PIP_RETRIES:-3}" --timeout 30 -r "$requirements"
  touch "$PY/.complete-$pinned"
fi
say "done"

#!/usr/bin/env bash
# One-stop set-up on Debian 12 as root (or with sudo): installs the missing packages, builds (the
# library, its tests and examples, and the Python package under python/), then runs the demo
# (`bash setup.sh demo`) or every test (`bash setup.sh test`, the Python tests included).
set -euo pipefail
cd "$(dirname "$0")"

mode=${1:-demo}
packages=(build-essential cmake pkg-config libfcl-dev libccd-dev libeigen3-dev liboctomap-dev
          libgtest-dev libgmock-dev libbenchmark-dev libbullet-dev libcairo2-dev libompl-dev
          python3-dev python3-numpy python3-pybind11 pybind11-dev python3-pytest
          python3-distributed python3-venv)
# CI's ThreadSanitizer stage (.ci/run) builds with clang and LLVM's OpenMP runtime, whose Archer
# tool tells ThreadSanitizer about OpenMP's synchronisation (GCC's libgomp is not instrumented);
# CI builds with Ninja; the Python benchmark's instruction counts (a test runs them) use valgrind.
[ "${1:-demo}" = test ] && packages+=(clang libomp-dev ninja-build valgrind)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "Installing: ${missing[*]}"
  sudo_cmd=""
  [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

build=${BUILD_DIR:-build}
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release
cmake --build "$build" -j2

case "$mode" in
  demo) "$build/examples/demo" ;;
  test) ctest --test-dir "$build" --output-on-failure -j2 ;;
  *) echo "usage: bash setup.sh [demo|test]" >&2; exit 2 ;;
esac

#!/usr/bin/env bash
# Consumes cube-collision the way a user's project does, and runs the result.
#
#   run.sh find_package <build dir> <work dir>   install to <work dir>/prefix, build a project that
#                                                only calls find_package(CubeCollision), run it;
#                                                check that an incompatible version is refused
#   run.sh pkg_config   <build dir> <work dir>   install, compile main.cpp with pkg-config's flags
#                                                exactly as docs/install.md shows, run it
#   run.sh subdirectory <source dir> <work dir>  configure a project that add_subdirectory()s the
#                                                source tree: the library target is there, the
#                                                tests, examples and benchmarks are not (set
#                                                CUBE_DOWNSTREAM_BUILD=1 to also build and run it)
#
# Honours CXX, CXXFLAGS and LDFLAGS (the sanitizer builds pass theirs). Offline: needs only the
# Debian packages that setup.sh installs.
set -euo pipefail

mode=$1
from=$2
work=$3
here=$(cd "$(dirname "$0")" && pwd)

rm -rf "$work"
mkdir -p "$work"
prefix="$work/prefix"

case "$mode" in
  find_package)
    cmake --install "$from" --prefix "$prefix"
    cmake -S "$here/find_package" -B "$work/build" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$prefix"
    cmake --build "$work/build"
    "$work/build/downstream" "$work/hierarchy.svg"
    # SameMajorVersion: asking for 1.0 of a 0.x install must fail to configure.
    if cmake -S "$here/find_package" -B "$work/build-v1" -DCMAKE_PREFIX_PATH="$prefix" \
      -DCUBE_REQUIRED_VERSION=1.0 >"$work/v1.log" 2>&1; then
      echo "find_package(CubeCollision 1.0) accepted a 0.x install" >&2
      exit 1
    fi
    grep -q "compatible with requested version" "$work/v1.log" || {
      cat "$work/v1.log" >&2
      echo "find_package(CubeCollision 1.0) failed for another reason than the version" >&2
      exit 1
    }
    echo "find_package(CubeCollision 1.0) refused, as it should"
    ;;
  pkg_config)
    cmake --install "$from" --prefix "$prefix"
    pc=$(find "$prefix" -name cube_collision.pc)
    export PKG_CONFIG_PATH="$(dirname "$pc")${PKG_CONFIG_PATH:+:$PKG_CONFIG_PATH}"
    # Exactly the command of docs/install.md, `c++ -std=c++17 main.cpp $(pkg-config --cflags --libs
    # cube_collision)`, in that order (the .pc file carries no -std= of its own or of FCL's):
    # only the sanitizer flags come before it, and an rpath for a shared build after it.
    # shellcheck disable=SC2046,SC2086
    (cd "$work" && ${CXX:-c++} ${CXXFLAGS:-} ${LDFLAGS:-} \
      -std=c++17 "$here/main.cpp" $(pkg-config --cflags --libs cube_collision) \
      -Wl,-rpath,"$(pkg-config --variable=libdir cube_collision)")
    "$work/a.out" "$work/hierarchy.svg"
    ;;
  subdirectory)
    cmake -S "$here/subdirectory" -B "$work/build" -DCMAKE_BUILD_TYPE=Release \
      -DCUBE_COLLISION_SOURCE_DIR="$from"
    targets=$(cmake --build "$work/build" --target help)
    grep -qw "cube_collision" <<<"$targets" || { echo "no cube_collision target" >&2; exit 1; }
    for t in cube_scenes cube_fcl_float demo cube_tests_api cube_tests_core cube_tests_threads cube_bench; do
      if grep -qw "$t" <<<"$targets"; then
        echo "target $t is built although cube-collision is not the top-level project" >&2
        exit 1
      fi
    done
    echo "add_subdirectory: library target present, tests/examples/benchmarks left out"
    if [ "${CUBE_DOWNSTREAM_BUILD:-0}" = 1 ]; then
      cmake --build "$work/build" -j2
      "$work/build/downstream" "$work/hierarchy.svg"
    fi
    ;;
  *)
    echo "usage: run.sh find_package|pkg_config|subdirectory <from> <work dir>" >&2
    exit 2
    ;;
esac
rm -rf "$work"

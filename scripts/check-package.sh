#!/usr/bin/env bash
# The library as a user gets it (docs/library.md): installs BUILD (default build/) into a fresh
# prefix and checks what is there, then builds and runs examples/ against the installed
# package (CMake and pkg-config) and, with --vendored, through add_subdirectory of this
# checkout. Exit 1 on the first problem, naming it.
#   bash scripts/check-package.sh [BUILD] [--vendored]
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
build=build
vendored=0
for a in "$@"; do
  case $a in
    --vendored) vendored=1 ;;
    -*) echo "usage: bash scripts/check-package.sh [BUILD] [--vendored]" >&2; exit 2 ;;
    *) build=$a ;;
  esac
done
fail() { echo "check-package: $*" >&2; exit 1; }
# Runs a step quietly; on failure shows its output and names it.
quiet() {
  if ! "$@" >"$work/step.log" 2>&1; then
    cat "$work/step.log" >&2
    fail "failed: $*"
  fi
}
[[ -f $build/CMakeCache.txt ]] || fail "$build: not a configured build (run scripts/test.sh first)"
prefix=$work/prefix
quiet cmake --install "$build" --prefix "$prefix"

# What the prefix holds: the headers, the library, its CMake package and .pc file, the CLI.
libdir=$(cd "$prefix" && ls -d lib*/ | head -1)
libdir=${libdir%/}
unexpected=$(cd "$prefix" && find . -type f -o -type l | sed 's|^\./||' | grep -Ev \
  "^include/afterimage/[a-z_]+\.(h|hpp)$|^$libdir/libafterimage\.(so[.0-9]*|a)$|^$libdir/cmake/Afterimage/[A-Za-z-]+\.cmake$|^$libdir/pkgconfig/afterimage\.pc$|^bin/afterimage$" || true)
[[ -z $unexpected ]] || fail "unexpected files in the install: $unexpected"
for f in include/afterimage/afterimage.h include/afterimage/afterimage.hpp \
  include/afterimage/version.h $libdir/cmake/Afterimage/AfterimageConfig.cmake \
  $libdir/cmake/Afterimage/AfterimageConfigVersion.cmake $libdir/pkgconfig/afterimage.pc bin/afterimage; do
  [[ -e $prefix/$f ]] || fail "the install lacks $f"
done
if grep -En '#include <(hwy|tbb|oneapi|OpenImageIO|embree|opencv)' "$prefix"/include/afterimage/*; then
  fail "a public header includes a dependency's header"
fi
shared=$(ls "$prefix/$libdir"/libafterimage.so 2>/dev/null || true)
if [[ -n $shared ]]; then
  # Its own dependencies: no Embree, no OpenCV. (Debian 12's libOpenImageIO links OpenCV's core,
  # imgproc, videoio and imgcodecs itself, so ldd lists those below it; our peer, opencv_photo,
  # is never there.)
  if readelf -d "$shared" | grep NEEDED | grep -Ei 'opencv|embree'; then
    fail "libafterimage.so links OpenCV or Embree"
  fi
  if ldd "$shared" | grep -Ei 'embree|opencv_photo'; then fail "libafterimage.so loads Embree or the OpenCV peer"; fi
  # Only the API is exported: the C functions and namespace afterimage::v0.
  leaked=$(nm -D --defined-only -C "$shared" | awk '{ $1 = ""; $2 = ""; print }' |
    grep -Ev '^ +(afterimage_|afterimage::v0::|typeinfo (name )?for afterimage::v0::|vtable for afterimage::v0::|AFTERIMAGE_)' || true)
  [[ -z $leaked ]] || fail "libafterimage.so exports more than the API: $(echo "$leaked" | head -5)"
  echo "check-package: $(basename "$shared"): $(nm -D --defined-only "$shared" | wc -l) exported symbols; needs $(readelf -d "$shared" | grep -c NEEDED) libraries, none of them Embree or OpenCV"
fi
"$prefix/bin/afterimage" --version

# The examples against the installed package, and a frame to read for read_sequence.
seq=$work/sequence
quiet "$prefix/bin/afterimage" render --scene motion --frames 6 --size 96x54 --out "$seq"
quiet cmake -S examples -B "$work/installed" -G Ninja -DCMAKE_PREFIX_PATH="$prefix" \
  -DAFTERIMAGE_EXAMPLE_SEQUENCE="$seq"
quiet cmake --build "$work/installed"
ctest --test-dir "$work/installed" --output-on-failure
# pkg-config, as a Makefile would link it.
export PKG_CONFIG_PATH=$prefix/$libdir/pkgconfig
cc -std=c99 examples/frame_loop.c -o "$work/frame_loop_pc" $(pkg-config --cflags --libs afterimage) \
  -Wl,-rpath,"$prefix/$libdir" $([[ -n $shared ]] || pkg-config --static --libs afterimage) -lm
quiet "$work/frame_loop_pc"
echo "check-package: examples built against the install (CMake and pkg-config) and ran"

if [[ $vendored == 1 ]]; then
  # Beside BUILD, so that ccache (when installed) finds the library's objects compiled there:
  # it hashes paths in the checkout relative to the build directory.
  vendored_build=$(dirname "$build")/$(basename "$build")-vendored
  rm -rf "$vendored_build"
  quiet cmake -S examples -B "$vendored_build" -G Ninja -DAFTERIMAGE_SOURCE_DIR="$root" \
    -DAFTERIMAGE_EXAMPLE_SEQUENCE="$seq"
  quiet cmake --build "$vendored_build" -j "$(nproc)"
  ctest --test-dir "$vendored_build" --output-on-failure
  echo "check-package: examples built through add_subdirectory of $root and ran"
fi

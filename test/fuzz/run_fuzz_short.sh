#!/bin/bash
# The libFuzzer targets (test/fuzz/README.md): builds one with clang++ (the main build may use g++)
# and runs it briefly over its seed corpus.
#   scene: the scene reader (scene_fuzz.cpp), seeds test/fuzz/corpus/ and config/scenes/, with
#          test/fuzz/fixtures/ as the fuzzed scenes' folder (a URDF, a mesh and keyframe files)
#   urdf:  the URDF reader (urdf_fuzz.cpp), seeds test/fuzz/corpus_urdf/
#   run_fuzz_short.sh TARGET SOURCE_DIR WORK_DIR [SECONDS]   build if needed, then fuzz (default 20 s)
#   run_fuzz_short.sh TARGET SOURCE_DIR WORK_DIR --build     build only (exit 0 when skipped)
# Exits 77 (ctest: skipped) when no clang++ builds with -fsanitize=fuzzer; scripts/install_deps.sh
# installs clang so that it normally runs. CORDE_FUZZ_CXX picks the compiler.
set -eu
target=$1
src=$2
work=$3
arg=${4:-20}
case "$target" in
  scene)
    mapfile -t sources < <(find "$src/src/core" -name "*.cpp" | sort)
    sources+=("$src/test/fuzz/scene_fuzz.cpp")
    libs=(-lyaml-cpp -lfcl -lccd -lassimp -lurdfdom_model -lconsole_bridge -ltinyxml2)
    seeds=("$src/test/fuzz/corpus" "$src/config/scenes")
    export CORDE_FUZZ_FIXTURES="$src/test/fuzz/fixtures" ;;
  urdf)
    # Only the library files the URDF reader needs.
    sources=("$src"/src/core/contact/{urdf_obstacles,urdf_checks}.cpp "$src"/src/core/io/file_read.cpp
      "$src"/test/fuzz/urdf_fuzz.cpp)
    libs=(-lassimp -lurdfdom_model -lconsole_bridge -ltinyxml2)
    seeds=("$src/test/fuzz/corpus_urdf") ;;
  *) echo "run_fuzz_short.sh: unknown target '$target' (scene or urdf)"; exit 2 ;;
esac
name="${target}_fuzz_short"
cxx=${CORDE_FUZZ_CXX:-}
if [ -z "$cxx" ]; then
  for c in clang++ clang++-16 clang++-15 clang++-14; do
    if command -v "$c" >/dev/null 2>&1; then cxx=$c; break; fi
  done
fi
mkdir -p "$work/obj" "$work/new_inputs"
probe="$work/probe.cpp"
printf '%s\n' '#include <cstddef>' '#include <cstdint>' \
  'extern "C" int LLVMFuzzerTestOneInput(const uint8_t*, size_t) { return 0; }' > "$probe"
if [ -z "$cxx" ] || ! "$cxx" -fsanitize=fuzzer "$probe" -o "$work/probe" >/dev/null 2>&1; then
  echo "$name: SKIPPED: no clang++ that builds with -fsanitize=fuzzer" \
    "(apt-get install clang, or set CORDE_FUZZ_CXX)"
  [ "$arg" = "--build" ] && exit 0  # nothing to build: the build itself does not fail
  exit 77
fi

# Objects are rebuilt when their source, or any header, is newer (two at a time).
bin="$work/${target}_fuzz"
flags="-std=c++17 -O1 -g -fsanitize=fuzzer-no-link,address,undefined"
flags="$flags -fno-sanitize-recover=undefined -I$src/include -isystem /usr/include/eigen3"
# The library's own headers only: the ROS adapter's (include/corde_sim/ros/) are not compiled here.
newest_header=$({ find "$src/include/corde_sim" -path "*/ros" -prune -o -name "*.h" -printf "%T@ %p\n";
  find "$src/src/core" -name "*.h" -printf "%T@ %p\n"; } | sort -n | tail -n 1 | cut -d" " -f2-)
stale=""
objects=()
for f in "${sources[@]}"; do
  o="$work/obj/$(echo "$f" | tr / _).o"  # the whole path: two folders may hold the same name
  objects+=("$o")
  if [ ! -f "$o" ] || [ "$f" -nt "$o" ] || [ "$newest_header" -nt "$o" ]; then
    stale="$stale $f"
  fi
done
if [ -n "$stale" ] || [ ! -x "$bin" ]; then
  # A failed build must not leave a binary that looks up to date.
  rm -f "$bin"
  echo "$name: building $bin with $cxx"
  # shellcheck disable=SC2086
  printf '%s\n' $stale | xargs -r -P 2 -I{} sh -c \
    "$cxx $flags -c {} -o $work/obj/\$(echo {} | tr / _).o"
  "$cxx" -fsanitize=fuzzer,address,undefined "${objects[@]}" "${libs[@]}" -o "$bin.tmp"
  mv "$bin.tmp" "$bin"
fi
[ "$arg" = "--build" ] && exit 0

# New inputs go to the work folder; the seed folders are only read. A crash, a sanitizer report,
# an input slower than 60 s or above 2 GB fails the test and leaves the input in WORK_DIR.
exec "$bin" -max_total_time="$arg" -max_len=4096 -timeout=60 -rss_limit_mb=2048 \
  -dict="$src/test/fuzz/$target.dict" -artifact_prefix="$work/" -print_final_stats=1 \
  "$work/new_inputs" "${seeds[@]}"

#!/usr/bin/env bash
# The installed project, as a user outside this tree sees it (issue 39):
#   1. cmake --install BUILD --prefix P puts the programs, the static
#      libraries, the headers, the package config, the .pc file and the
#      configs where docs/install.md says;
#   2. every installed header compiles on its own, with only the flags
#      pkg-config gives (its declared dependencies);
#   3. tests/install/consumer, configured against P with find_package(lanedet),
#      builds and finds the lanes of a frame rendered by P/bin/lane;
#   4. the same program built with g++ and pkg-config alone does too;
#   5. P/bin/lane --version prints the project's version.
#
# usage: install_test.sh BUILD_DIR SOURCE_DIR VERSION
set -euo pipefail
build=$1
src=$2
version=$3
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail() {
  echo "FAIL: $*" >&2
  exit 1
}
prefix=$dir/prefix

# 1. The files.
cmake --install "$build" --prefix "$prefix" >"$dir/install.log"
libdir=$(sed -n 's/^libdir=\${prefix}\///p' "$(find "$prefix" -name lanedet.pc -print -quit)")
[ -n "$libdir" ] || fail "no lanedet.pc installed"
for f in bin/lane "$libdir/liblanedet_core.a" "$libdir/liblanedet_decode.a" \
  "$libdir/cmake/lanedet/lanedetConfig.cmake" "$libdir/cmake/lanedet/lanedetConfigVersion.cmake" \
  "$libdir/pkgconfig/lanedet.pc" include/lane/detector/detector.h include/lane/decode/image_decoder.h \
  include/lane/config/config.h share/lanedet/configs/synthetic.json; do
  [ -e "$prefix/$f" ] || fail "not installed: $f"
done
echo "ok: $(find "$prefix" -type f | wc -l) files installed"

# 2. Each header on its own.
export PKG_CONFIG_PATH=$prefix/$libdir/pkgconfig
read -r -a cflags <<<"$(pkg-config --cflags lanedet)"
headers=$(cd "$prefix/include" && find lane -name '*.h' | sort)
count=0
for h in $headers; do
  printf '#include "%s"\n' "$h" >"$dir/one.cc"
  g++ -std=c++17 -fsyntax-only -Wall -Werror "${cflags[@]}" "$dir/one.cc" 2>"$dir/header.err" ||
    { cat "$dir/header.err" >&2; fail "$h does not compile on its own"; }
  count=$((count + 1))
done
[ "$count" -ge 20 ] || fail "only $count headers installed"
echo "ok: $count headers compile on their own"

# 3. find_package(lanedet).
"$prefix/bin/lane" render --config "$prefix/share/lanedet/configs/synthetic.json" --count 1 \
  --num-lanes 3 --format jpg --output "$dir/frames" >/dev/null
frame=$dir/frames/000000.jpg
[ -f "$frame" ] || fail "lane render wrote no frame"
cmake -S "$src/tests/install/consumer" -B "$dir/consumer" -DCMAKE_PREFIX_PATH="$prefix" \
  >"$dir/configure.log" 2>&1 || { cat "$dir/configure.log" >&2; fail "find_package(lanedet)"; }
cmake --build "$dir/consumer" >"$dir/build.log" 2>&1 || { cat "$dir/build.log" >&2; fail "consumer build"; }
"$dir/consumer/detect_one" "$prefix/share/lanedet/configs/synthetic.json" "$frame" >"$dir/cmake.out" ||
  { cat "$dir/cmake.out" >&2; fail "the find_package consumer found no lane"; }
echo "ok: find_package consumer: $(tail -1 "$dir/cmake.out")"

# 4. pkg-config alone.
read -r -a libs <<<"$(pkg-config --libs lanedet)"
g++ -std=c++17 -O1 "${cflags[@]}" "$src/tests/install/consumer/detect_one.cc" -o "$dir/detect_pc" \
  "${libs[@]}" 2>"$dir/pc.err" || { cat "$dir/pc.err" >&2; fail "pkg-config consumer build"; }
"$dir/detect_pc" "$prefix/share/lanedet/configs/synthetic.json" "$frame" >"$dir/pc.out" ||
  { cat "$dir/pc.out" >&2; fail "the pkg-config consumer found no lane"; }
cmp -s "$dir/cmake.out" "$dir/pc.out" || fail "the two consumers disagree"
echo "ok: pkg-config consumer: $(tail -1 "$dir/pc.out")"

# 5. One version.
grep -q "^lane $version " <<<"$("$prefix/bin/lane" --version)" || fail "lane --version is not $version"
[ "$(pkg-config --modversion lanedet)" = "$version" ] || fail "lanedet.pc's version is not $version"
echo "ok: version $version"

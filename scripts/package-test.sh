#!/usr/bin/env bash
# The Debian package end to end (issue 39), as root on the machine itself
# (CI runs as root; elsewhere this script says so and skips):
#   1. cpack builds build/lanedet_<VERSION>_<arch>.deb;
#   2. its contents and control fields are what cmake/package.cmake says
#      (Depends: computed by dpkg-shlibdeps, the unit, the conffile 0600);
#   3. lintian reports no tag beyond those its overrides explain;
#   4. systemd-analyze verifies the unit (syntax, hardening keys, paths);
#   5. apt installs it, /usr/bin/lane --version and lane-server --version
#      print VERSION, and lane-server serves a health check with the flags
#      of /etc/default/lane-server (started directly: CI has no systemd as
#      PID 1, so the unit is verified, not started);
#   6. apt purges it: the programs and the conffile are gone.
#
# usage: scripts/package-test.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
version=$(head -1 VERSION)
if [ "$(id -u)" -ne 0 ]; then
  echo "package-test: skipped: needs root (it installs and purges the package)"
  exit 0
fi
if dpkg -s lanedet >/dev/null 2>&1; then
  echo "package-test: lanedet is installed already; not touching it" >&2
  exit 1
fi
fail() {
  echo "package-test: FAIL: $*" >&2
  exit 1
}
export DEBIAN_FRONTEND=noninteractive

# 1. The package.
rm -f "$build"/lanedet_*.deb
(cd "$build" && cpack -G DEB >cpack.log 2>&1) || { cat "$build/cpack.log" >&2; fail "cpack"; }
deb=$(ls "$build"/lanedet_"$version"_*.deb)
echo "package-test: built $(basename "$deb") ($(du -k "$deb" | cut -f1) kB)"

# 2. Contents and control.
dpkg-deb -c "$deb" >"$build/deb-contents.txt"
for f in ./usr/bin/lane ./usr/bin/lane-server ./usr/bin/lane-client \
  ./lib/systemd/system/lane-server.service ./etc/default/lane-server \
  ./usr/lib/liblanedet_core.a ./usr/include/lane/detector/detector.h ./usr/lib/pkgconfig/lanedet.pc \
  ./usr/share/lanedet/configs/synthetic.json ./usr/share/doc/lanedet/copyright; do
  grep -q " $f\$" "$build/deb-contents.txt" || fail "$f is not in the package"
done
grep -q '^-rw------- root/root .* ./etc/default/lane-server$' "$build/deb-contents.txt" ||
  fail "/etc/default/lane-server is not 0600 root"
[ "$(dpkg-deb -f "$deb" Version)" = "$version" ] || fail "package version is not $version"
depends=$(dpkg-deb -f "$deb" Depends)
for lib in libopencv-core libgrpc++ libprotobuf libprometheus-cpp-core libjpeg62-turbo; do
  grep -q "$lib" <<<"$depends" || fail "Depends lacks $lib (dpkg-shlibdeps): $depends"
done
grep -q conffiles <<<"$(dpkg-deb --ctrl-tarfile "$deb" | tar -t)" || fail "no conffiles"
echo "package-test: contents and Depends ok ($(wc -l <"$build/deb-contents.txt") entries)"

# 3. lintian (installed on demand: the package test is its only user).
command -v lintian >/dev/null || apt-get install -y -q lintian >/dev/null
lintian --tag-display-limit 0 "$deb" 2>&1 | grep -v 'running with root privileges' >"$build/lintian.txt" || true
if [ -s "$build/lintian.txt" ]; then
  cat "$build/lintian.txt" >&2
  fail "lintian tags beyond deploy/debian/lintian-overrides"
fi
echo "package-test: lintian clean (explained tags: deploy/debian/lintian-overrides)"

# 4-5. Install, versions, a served health check.
apt-get install -y -q "$(realpath "$deb")" >"$build/apt-install.log" 2>&1 ||
  { cat "$build/apt-install.log" >&2; fail "apt install"; }
trap 'apt-get purge -y -q lanedet >/dev/null 2>&1 || true' EXIT
if command -v systemd-analyze >/dev/null; then
  systemd-analyze verify /lib/systemd/system/lane-server.service >"$build/unit.log" 2>&1 ||
    { cat "$build/unit.log" >&2; fail "systemd-analyze verify lane-server.service"; }
  echo "package-test: systemd-analyze verify: ok"
fi
grep -q "^lane $version " <<<"$(/usr/bin/lane --version)" || fail "/usr/bin/lane --version: $(/usr/bin/lane --version)"
grep -q "^lane-server $version " <<<"$(/usr/bin/lane-server --version)" || fail "lane-server --version"
grep -q "^lane-client $version " <<<"$(/usr/bin/lane-client --version)" || fail "lane-client --version"
[ "$(stat -c %a /etc/default/lane-server)" = 600 ] || fail "/etc/default/lane-server is not 0600"
# The unit's flags, on free ports (the defaults may be taken on a CI host).
# shellcheck disable=SC1091
. /etc/default/lane-server
args=$(sed -e 's/--address=[^ ]*/--address=127.0.0.1:0/' \
  -e 's/--metrics_address=[^ ]*/--metrics_address=/' <<<"$LANE_SERVER_ARGS")
log=$(mktemp)
# shellcheck disable=SC2086
/usr/bin/lane-server $args 2>"$log" &
pid=$!
port=
for _ in $(seq 1 100); do
  port=$(grep -m1 -o '"grpc_port":[0-9]*' "$log" | cut -d: -f2 || true)
  [ -n "$port" ] && break
  sleep 0.1
done
[ -n "$port" ] || { kill "$pid" 2>/dev/null; cat "$log" >&2; fail "lane-server did not report its port"; }
/usr/bin/lane-client health --target "127.0.0.1:$port" >/dev/null ||
  { kill "$pid"; fail "health check of the installed lane-server"; }
kill -TERM "$pid"
wait "$pid" || fail "lane-server did not stop cleanly on SIGTERM"
rm -f "$log"
echo "package-test: installed; versions $version; lane-server served health with /etc/default/lane-server's flags"

# 6. Purge.
trap - EXIT
apt-get purge -y -q lanedet >"$build/apt-purge.log" 2>&1 || { cat "$build/apt-purge.log" >&2; fail "apt purge"; }
[ ! -e /usr/bin/lane ] && [ ! -e /etc/default/lane-server ] &&
  [ ! -e /lib/systemd/system/lane-server.service ] || fail "files left after purge"
echo "package-test: purged"

#!/usr/bin/env bash
# Installs every Debian 12 package the project needs to build, test and run.
# Idempotent: skips apt-get when everything is already installed.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config git ca-certificates curl
  libopencv-dev          # image decoding, IPM remap, filtering, drawing, video and live input
  gstreamer1.0-plugins-base   # GStreamer pipelines as inputs (videotestsrc, videoconvert, appsink: tests/client/live_input_test.py)
  ffmpeg                 # tests only: serves a live MJPEG-over-HTTP stream on loopback (tests/client/live_input_test.py)
  libjpeg62-turbo-dev    # decode/: JPEG frames decoded with bounded work (scan limit, deadline)
  libpng-dev zlib1g-dev  # decode/: PNG frames inflated only as far as their rows need
  libeigen3-dev          # linear algebra: Bezier least squares, TLS line fits
  libabsl-dev            # absl::Status/StatusOr, flags, strings
  libcli11-dev           # command lines of lane and lane-client (header-only, CLI11 2.1)
  nlohmann-json3-dev     # config files and JSON Lines results
  libgtest-dev libgmock-dev   # unit and integration tests
  libbenchmark-dev       # benchmarks
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler   # the service
  prometheus-cpp-dev     # service metrics (families, text format)
  libcivetweb-dev        # the metrics port's HTTP server: /metrics, /healthz, /readyz
  prometheus             # tests: a real scrape; promtool checks the scrape and the alert rules
  libmatio-dev           # Caltech Lanes .ccvl label files (MAT v5)
  libssl-dev             # libcrypto: HMAC-SHA-256 sealing of the service's resume states; SHA-256 of lane backfill's output trailers
  clang-format
  clang libclang-rt-14-dev   # fuzz/: libFuzzer targets (scripts/fuzz.sh, a step of the test command)
  openssl                # tests/server/security_test: a test CA made at test time
  python3-yaml           # tests/deploy: parses the compose file and Kubernetes manifests
  python3-grpcio python3-protobuf python3-numpy   # client/python: the Python client and tests/python (numpy: array frames; cv2 stays optional)
  python3-setuptools python3-venv python3-pip     # pip install ./client/python (tests/python/install_test.sh)
  lintian                # the .deb's check (scripts/package-test.sh)
  nginx                  # deploy/nginx: the camera-affinity proxy (tests/deploy, deploy/proxy-cluster.sh)
  libssl-dev             # server/live_view.cc: the live view's login cookie (HMAC-SHA256, libcrypto)
  chromium chromium-driver python3-selenium   # tests/server/live_view_browser_test.py: the live view in headless Chromium
)

missing=()
for p in "${PACKAGES[@]}"; do
  [ "$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null)" = "install ok installed" ] || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"

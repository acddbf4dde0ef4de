#!/usr/bin/env bash
# Installs Waymark's build and test dependencies from Debian 12 packages.
# Idempotent: packages already present are skipped, so a second run does no network work.
#
#   scripts/install-deps.sh               everything: build, tests, benchmarks, demo (make run/test)
#   scripts/install-deps.sh --build-only  only what building the binaries needs (docker/Dockerfile's
#                                         build stage): no ccache, git, test photos, openssl
#   scripts/install-deps.sh --peers       everything above plus the laser SLAM peers of
#                                         `bench/laser/laser_benchmark.sh --peers` and
#                                         bench/laser/laser_peer_mrpt.sh
#                                         (MRPT's icp-slam and carmen2rawlog; `make peers-deps`).
#                                         Opt-in: make run/test do not need them.
set -euo pipefail

BUILD_ONLY=0
PEERS=0
case "${1:-}" in
  "") ;;
  --build-only) BUILD_ONLY=1 ;;
  --peers) PEERS=1 ;;
  *) echo "usage: $0 [--build-only | --peers]" >&2; exit 2 ;;
esac

PACKAGES=(
  build-essential cmake ninja-build ccache pkg-config git
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  libopencv-dev libeigen3-dev libabsl-dev libsqlite3-dev
  libpq-dev  # the PostgreSQL stores (storage/postgres): several servers on one database
  libceres-dev  # the laser sessions' pose graph (server/laser_slam/mapping)
  libssl-dev  # SHA-256 of token secrets and enrolled images (storage/sha256), TLS (a gRPC dependency)
  libgtest-dev libgmock-dev libbenchmark-dev
  libcli11-dev libspdlog-dev libfmt-dev nlohmann-json3-dev
  prometheus-cpp-dev  # metrics endpoint (server/service/operations/metrics)
  zlib1g-dev libbz2-dev  # compressed CARMEN laser logs (client/datasets/carmen_log)
  blender-data  # real 360-degree photos for the rotation test set (bench/crossing/rotation_set.h)
  openssl  # test certificates (tests/integration/tls_test.cc)
  postgresql-15  # the server the PostgreSQL tests start for themselves (tests/support/postgres_server.sh)
  python3-protobuf  # a strict parser of the server's answers (tests/fuzz/answers_utf8_test.sh)
  # make fuzz (scripts/fuzz.sh): clang with libFuzzer and the sanitizers' runtimes, and
  # llvm-symbolizer for their reports
  clang-14 libclang-rt-14-dev llvm-14
)

# Not needed to build the binaries: the compiler cache, git, test photos, test certificates, the
# PostgreSQL server of the tests, the tests' Python protobuf and the fuzzing toolchain.
NOT_FOR_BUILD=" ccache git blender-data openssl postgresql-15 python3-protobuf clang-14 libclang-rt-14-dev llvm-14 "
if [ "$BUILD_ONLY" -eq 1 ]; then
  kept=()
  for p in "${PACKAGES[@]}"; do
    [[ "$NOT_FOR_BUILD" == *" $p "* ]] || kept+=("$p")
  done
  PACKAGES=("${kept[@]}")
fi
if [ "$PEERS" -eq 1 ]; then
  PACKAGES+=(
    mrpt-apps  # icp-slam, carmen2rawlog (MRPT 2.5.8): the peer of bench/laser/laser_peer_mrpt.sh
    mrpt-common  # icp-slam's example config icp-slam_demo_classic.ini, the "shipped" settings
    jq bzip2 gzip  # the laser benchmark's JSON, and the compressed CARMEN logs it converts for MRPT
  )
fi

# The tests' node packages (tests/js/package.json: MCAP/rosbag2 writers, the Foxglove WebSocket
# client) need node and npm; a machine that already has them (any version >= 18) keeps its own.
if [ "$BUILD_ONLY" -eq 0 ] && ! { command -v node >/dev/null && command -v npm >/dev/null; }; then
  PACKAGES+=(nodejs npm)
fi

# tests/js/node_modules from its lock file, once per change of the lock (after apt, which may
# have just installed npm). Called on every exit path below.
install_test_node_packages() {
  [ "$BUILD_ONLY" -eq 0 ] || return 0
  local dir
  dir="$(cd "$(dirname "$0")/.." && pwd)/tests/js"
  [ -f "$dir/package-lock.json" ] || return 0
  if [ -f "$dir/node_modules/.waymark-lock" ] && cmp -s "$dir/package-lock.json" "$dir/node_modules/.waymark-lock"; then
    return 0
  fi
  echo "install-deps: npm ci in tests/js"
  (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error) || {
    echo "install-deps: npm ci in tests/js failed (is the npm registry reachable?)" >&2; exit 1; }
  cp "$dir/package-lock.json" "$dir/node_modules/.waymark-lock"
}

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  install_test_node_packages
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null; then SUDO="sudo"; else
    echo "install-deps: missing packages (${missing[*]}) and not root; run as root or install them" >&2
    exit 1
  fi
fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
# The tests run a PostgreSQL cluster of their own; the package's default cluster (and the server
# its postinst would start on port 5432) is not wanted. Read by postgresql-common at install time.
if [[ " ${missing[*]} " == *" postgresql-15 "* ]]; then
  $SUDO mkdir -p /etc/postgresql-common/createcluster.d
  echo "create_main_cluster = false" | $SUDO tee /etc/postgresql-common/createcluster.d/waymark.conf >/dev/null
fi
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
install_test_node_packages

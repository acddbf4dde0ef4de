#!/usr/bin/env bash
# make docker-test: build the Waymark image and smoke-test it with a real container engine.
#
# No registry is reachable, so this script makes everything from Debian packages: it installs
# docker.io, docker-compose (v1) and debootstrap when missing, builds the `debian:bookworm` base with
# debootstrap from this machine's Debian mirror, starts its own containerd + dockerd with all their
# state under a temporary directory (own socket, no bridge, no iptables; containers use the host
# network), builds docker/Dockerfile, and runs the compose stack of docker/compose.yaml:
#
#   server healthy -> tokens made with `docker exec` -> auth refused without a token -> enroll
#   (mapper) and recognize (robot) through the container -> the example robot service (simulator)
#   runs a SLAM session -> metrics answer -> restart: data still there -> server re-created with
#   TLS on the same volume: data still there, TLS client works, plaintext client refused ->
#   `docker stop` is graceful (exit 0, "stopped" logged) -> the scale-out profile (`--profile
#   fleet`): PostgreSQL 15 and three servers healthy -> enroll on one server, recognize on another
#   and through the client's server list -> the example robot streams a SLAM session over the
#   fleet, the server serving it is SIGKILLed, the same session goes on on another server and the
#   robot ends normally -> teardown.
#
# Everything it started is stopped and removed on exit, success or not (trap EXIT); packages it
# installed stay installed. Logs are kept in out/docker-test/. Run as root on Debian 12.
#
# Environment:
#   WAYMARK_SMOKE_IMAGES  folder of photos DIR/<place>/<any>.jpg (>= 5 places, >= 2 photos each);
#                         default: ../shared/data/vpr/gardenspoint_sfu_triplets_sample, else views
#                         made by BUILD_DIR/bin/waymark-demo-data (blender-data) if that is built
#   WAYMARK_DEBIAN_MIRROR Debian mirror for debootstrap and the images (default: this machine's)
#   WAYMARK_BASE_TAR      reuse (or save) the debootstrapped base as this tarball (development)
#   WAYMARK_DOCKER_HOST   use this running engine (unix:///...) instead of starting one: no
#                         install, no base image when present, the image build uses its cache
#   WAYMARK_DOCKER_TMP    where the temporary engine keeps its state (default /tmp)
#   BUILD_DIR             host build tree for the waymark-demo-data fallback (default build)
set -Eeuo pipefail

REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
IMAGE=waymark:local
PROJECT=waymark-smoke
LOG_DIR="$REPO/out/docker-test"
START=$SECONDS
STEP_START=$SECONDS
STEP_NAME=""
STEP_TIMES=()
RESULT="FAILED"

# ---- output --------------------------------------------------------------------------------------
stamp() { printf '[%(%H:%M:%S)T +%4ds]' -1 "$((SECONDS - START))"; }
end_step() {
  if [ -n "$STEP_NAME" ]; then STEP_TIMES+=("$(printf '%5ds  %s' "$((SECONDS - STEP_START))" "$STEP_NAME")"); fi
  STEP_NAME=""
}
step() { end_step; STEP_NAME=$*; STEP_START=$SECONDS; printf '\n%s == %s\n' "$(stamp)" "$*"; }
info() { printf '%s    %s\n' "$(stamp)" "$*"; }
fail() { printf '%s FAIL: %s\n' "$(stamp)" "$*" >&2; exit 1; }
# check DESCRIPTION COMMAND...: runs the command, says ok or fails with its output.
check() {
  local what=$1 out; shift
  if out=$("$@" 2>&1); then info "ok: $what"; else printf '%s\n' "$out" | tail -20 >&2; fail "$what"; fi
}

# ---- state for cleanup ---------------------------------------------------------------------------
WORK=""
CONTAINERD_PID=""
DOCKERD_PID=""
POLICY_RC_CREATED=0
OWN_ENGINE=1
# Host paths dockerd/containerd create outside their --data-root/--exec-root/state folders; the
# ones that did not exist before are removed again (only while empty).
HOST_PATHS=(/run/docker/plugins /run/docker /run/containerd/s /run/containerd /etc/docker/key.json)
CREATED_PATHS=()

cleanup() {
  local rc=$?
  set +e
  trap - EXIT INT TERM ERR
  end_step
  if [ -n "${DOCKER_HOST:-}" ] && docker info >/dev/null 2>&1; then
    printf '\n%s == teardown\n' "$(stamp)"
    local cid
    for cid in $(docker ps -aq --filter "label=com.docker.compose.project=$PROJECT" 2>/dev/null); do
      docker logs -t "$cid" > "$LOG_DIR/container-$(docker inspect -f '{{.Name}}' "$cid" | tr -d /).log" 2>&1
    done
    compose down -v --remove-orphans > "$LOG_DIR/compose-down.log" 2>&1 ||
      info "compose down failed (see $LOG_DIR/compose-down.log)"
    if [ "$OWN_ENGINE" -eq 1 ]; then
      cid=$(docker ps -aq)
      [ -z "$cid" ] || docker rm -f $cid > /dev/null
    fi
  fi
  [ "$OWN_ENGINE" -eq 1 ] && stop_engine
  local path
  for path in "${CREATED_PATHS[@]}"; do
    if [ -d "$path" ]; then rmdir "$path" 2>/dev/null || info "left $path (not empty)"; else rm -f "$path"; fi
  done
  if [ "$POLICY_RC_CREATED" -eq 1 ]; then rm -f /usr/sbin/policy-rc.d; fi
  if [ -n "$WORK" ] && [ -d "$WORK" ]; then
    info "removing $WORK"
    unmount_under "$WORK"
    rm -rf "$WORK" || info "could not remove $WORK"
    local proc
    for proc in /proc/[0-9]*; do
      if { tr '\0' ' ' < "$proc/cmdline"; } 2>/dev/null | grep -qF "$WORK"; then
        info "warning: process ${proc#/proc/} still refers to $WORK: $(tr '\0' ' ' < "$proc/cmdline")"
      fi
    done
  fi
  if [ ${#STEP_TIMES[@]} -gt 0 ]; then
    printf '\nStep times:\n'
    printf '  %s\n' "${STEP_TIMES[@]}"
  fi
  [ "$rc" -eq 0 ] && RESULT="PASSED"
  printf '\n%s docker-test %s in %dm%02ds (logs: %s)\n' "$(stamp)" "$RESULT" \
    "$(((SECONDS - START) / 60))" "$(((SECONDS - START) % 60))" "$LOG_DIR"
  exit "$rc"
}
trap cleanup EXIT
trap 'fail "line $LINENO: $BASH_COMMAND (exit $?)"' ERR
trap 'exit 130' INT
trap 'exit 143' TERM

# Unmounts everything mounted at or below $1, deepest first.
unmount_under() {
  local m
  for m in $(awk -v p="$1" '$5 == p || index($5, p "/") == 1 { print $5 }' /proc/self/mountinfo | sort -r); do
    umount "$m" 2>/dev/null || umount -l "$m" 2>/dev/null || info "could not unmount $m"
  done
}

# Sends TERM to a process we started, waits up to $2 seconds, then KILL.
stop_pid() {
  local pid=$1 wait_s=$2 i
  [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null || return 0
  kill -TERM "$pid" 2>/dev/null
  for ((i = 0; i < wait_s * 10; i++)); do kill -0 "$pid" 2>/dev/null || return 0; sleep 0.1; done
  info "process $pid did not stop in ${wait_s}s: killing it"
  kill -KILL "$pid" 2>/dev/null
  wait "$pid" 2>/dev/null
}

stop_engine() {
  [ -n "$DOCKERD_PID$CONTAINERD_PID" ] || return 0
  info "stopping dockerd and containerd"
  stop_pid "$DOCKERD_PID" 30
  # Container shims left behind (only if containers were still running): ours are the ones
  # talking to our containerd socket.
  local proc
  for proc in /proc/[0-9]*; do
    if { tr '\0' ' ' < "$proc/cmdline"; } 2>/dev/null | grep -q "containerd-shim.*-address $WORK/containerd.sock"; then
      stop_pid "${proc#/proc/}" 5
    fi
  done
  stop_pid "$CONTAINERD_PID" 15
  DOCKERD_PID=""
  CONTAINERD_PID=""
}

# ---- helpers -------------------------------------------------------------------------------------
# Debian's docker client (/usr/bin/docker), whatever else is on PATH; talks to $DOCKER_HOST.
docker() { /usr/bin/docker "$@"; }
# Every profile is on: services start only when named (or as a named one's dependency).
compose() {
  docker-compose -f "$REPO/docker/compose.yaml" -p "$PROJECT" --profile robot --profile fleet \
    --profile fleet-robot "$@"
}

# A TCP port nobody listens on (the containers use the host network).
free_port() {
  local port
  for _ in $(seq 200); do
    port=$((20000 + RANDOM % 30000))
    if ! (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then echo "$port"; return 0; fi
  done
  fail "no free TCP port found"
}

# The Debian mirror (and security mirror) this machine's apt uses.
apt_uris() {
  local f
  for f in /etc/apt/sources.list.d/*.sources; do
    if [ -f "$f" ]; then sed -n 's/^[[:space:]]*URIs:[[:space:]]*//p' "$f" | tr ' ' '\n'; fi
  done
  for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
    if [ -f "$f" ]; then sed -nE 's/^[[:space:]]*deb[[:space:]]+(\[[^]]*\][[:space:]]+)?([^[:space:]]+).*/\2/p' "$f"; fi
  done | sed 's:/*$::'
  return 0
}

# run_waymark [docker run options...] -- ARGS...: the image's `waymark` CLI as a client container on
# the host network, with the photos mounted at /images and the TLS folder at /tls. It calls
# $TARGET (default: the single server).
run_waymark() {
  local opts=()
  while [ "$1" != "--" ]; do opts+=("$1"); shift; done
  shift
  docker run --rm --network host -v "$WORK/images:/images:ro" -v "$WORK/tls:/tls:ro" \
    -e WAYMARK_SERVER="${TARGET:-127.0.0.1:$PORT}" "${opts[@]}" --entrypoint waymark "$IMAGE" "$@"
}
as_admin() { WAYMARK_TOKEN=$ADMIN_TOKEN run_waymark -e WAYMARK_TOKEN "$@"; }
as_mapper() { WAYMARK_TOKEN=$MAPPER_TOKEN run_waymark -e WAYMARK_TOKEN "$@"; }
as_robot() { WAYMARK_TOKEN=$ROBOT_TOKEN run_waymark -e WAYMARK_TOKEN "$@"; }

server_cid() { compose ps -q "${1:-server}"; }

# Waits until a service's container (default: server) is healthy (the servers' HEALTHCHECK runs
# `waymark health`); fails with its logs if it exits, turns unhealthy or takes longer than $1 s.
wait_healthy() {
  local limit=$1 service=${2:-server} cid status running
  cid=$(server_cid "$service")
  [ -n "$cid" ] || fail "no $service container"
  for ((i = 0; i < limit; i++)); do
    status=$(docker inspect -f '{{if .State.Health}}{{.State.Health.Status}}{{else}}none{{end}}' "$cid")
    running=$(docker inspect -f '{{.State.Running}}' "$cid")
    if [ "$status" = healthy ]; then info "$service healthy after ${i}s"; return 0; fi
    if [ "$running" != true ] || [ "$status" = unhealthy ] || [ "$status" = none ]; then
      docker logs --tail 30 "$cid" >&2
      docker inspect -f '{{json .State}}' "$cid" >&2
      fail "$service container is $status (running=$running)"
    fi
    sleep 1
  done
  docker logs --tail 30 "$cid" >&2
  fail "$service not healthy within ${limit}s (status: $status)"
}

# The recognition result of one image (JSON), checked for crossing and heading (or rejection).
expect_recognized() {
  local who=$1 image=$2 crossing=$3 heading=$4 out; shift 4
  out=$("$who" "$@" -- --json recognize smoke "$image") || { echo "$out" >&2; fail "recognize $image"; }
  grep -q '"recognized": true' <<<"$out" && grep -q "\"crossing\": \"$crossing\"" <<<"$out" &&
    grep -q "\"heading_deg\": $heading" <<<"$out" ||
    { echo "$out" | head -40 >&2; fail "$image: expected $crossing at heading $heading"; }
  info "ok: $image -> $crossing, heading $heading"
}
expect_rejected() {
  local who=$1 image=$2 out; shift 2
  out=$("$who" "$@" -- --json recognize smoke "$image") || { echo "$out" >&2; fail "recognize $image"; }
  grep -q '"recognized": false' <<<"$out" || { echo "$out" | head -40 >&2; fail "$image: expected not recognized"; }
  info "ok: $image (a place not enrolled) -> not recognized"
}
# expect_error CODE DESCRIPTION COMMAND...: the command must fail with that gRPC status code.
expect_error() {
  local code=$1 what=$2 out; shift 2
  if out=$("$@" 2>&1); then echo "$out" >&2; fail "$what: succeeded, expected $code"; fi
  grep -q "$code" <<<"$out" || { echo "$out" >&2; fail "$what: expected $code"; }
  info "ok: $what -> $(grep -o "$code" <<<"$out" | head -1)"
}

# ---- 1. host -------------------------------------------------------------------------------------
step "checks and packages"
[ "$(id -u)" -eq 0 ] || fail "run as root (it installs packages and starts its own dockerd)"
command -v apt-get >/dev/null || fail "needs Debian 12 (apt-get)"
mkdir -p "$LOG_DIR"
rm -f "$LOG_DIR"/*.log
info "repository $REPO, logs in $LOG_DIR"

if [ -n "${WAYMARK_DOCKER_HOST:-}" ]; then
  OWN_ENGINE=0
  command -v docker-compose >/dev/null && [ -x /usr/bin/docker ] ||
    fail "WAYMARK_DOCKER_HOST needs docker.io and docker-compose installed"
else
  PACKAGES=(docker.io docker-compose debootstrap openssl)
  missing=()
  for p in "${PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -eq 0 ]; then
    info "packages present: ${PACKAGES[*]}"
  else
    info "installing ${missing[*]}"
    # Installing docker.io must not start the system's docker service: policy-rc.d says no.
    if [ ! -e /usr/sbin/policy-rc.d ]; then
      printf '#!/bin/sh\nexit 101\n' > /usr/sbin/policy-rc.d
      chmod 755 /usr/sbin/policy-rc.d
      POLICY_RC_CREATED=1
    fi
    export DEBIAN_FRONTEND=noninteractive
    APT=(apt-get -o DPkg::Lock::Timeout=600 -y -q --no-install-recommends)
    if ! "${APT[@]}" install "${missing[@]}" > "$LOG_DIR/apt.log" 2>&1; then
      apt-get -o DPkg::Lock::Timeout=600 -q update >> "$LOG_DIR/apt.log" 2>&1 ||
        { tail -20 "$LOG_DIR/apt.log" >&2; fail "apt-get update"; }
      "${APT[@]}" install "${missing[@]}" >> "$LOG_DIR/apt.log" 2>&1 ||
        { tail -20 "$LOG_DIR/apt.log" >&2; fail "apt-get install ${missing[*]}"; }
    fi
    if [ "$POLICY_RC_CREATED" -eq 1 ]; then rm -f /usr/sbin/policy-rc.d; POLICY_RC_CREATED=0; fi
  fi
fi
info "$(/usr/bin/docker --version); $(docker-compose --version)"

# Photos to enroll: five places, two photos each ("000" and "180"), the sixth place as a stranger.
WORK=$(mktemp -d "${WAYMARK_DOCKER_TMP:-/tmp}/waymark-docker-test.XXXXXX")
chmod 755 "$WORK"
mkdir -p "$WORK/images/enroll" "$WORK/images/unknown" "$WORK/tls"
SOURCE=${WAYMARK_SMOKE_IMAGES:-$REPO/../shared/data/vpr/gardenspoint_sfu_triplets_sample}
if [ -z "${WAYMARK_SMOKE_IMAGES:-}" ] && [ ! -d "$SOURCE" ] &&
   [ -x "$REPO/${BUILD_DIR:-build}/bin/waymark-demo-data" ]; then
  info "no $SOURCE: making views from blender-data with ${BUILD_DIR:-build}/bin/waymark-demo-data"
  "$REPO/${BUILD_DIR:-build}/bin/waymark-demo-data" "$WORK/demo" > "$LOG_DIR/demo-data.log" 2>&1 ||
    fail "waymark-demo-data (see $LOG_DIR/demo-data.log)"
  SOURCE=$WORK/demo/db
fi
[ -d "$SOURCE" ] || fail "no photos: set WAYMARK_SMOKE_IMAGES=DIR (DIR/<place>/<photo>.jpg), provide \
../shared/data/vpr, or build waymark-demo-data (make build) with blender-data installed"
PLACES=()
STRANGER_PHOTO=""
for place_dir in "$SOURCE"/*/; do
  place=$(basename "$place_dir")
  [ "$place" = unknown ] && continue
  mapfile -t photos < <(find "$place_dir" -type f \( -iname '*.jpg' -o -iname '*.png' \) | sort | head -2)
  [ ${#photos[@]} -eq 2 ] || continue
  if [ ${#PLACES[@]} -lt 5 ]; then
    PLACES+=("$place")
    mkdir -p "$WORK/images/enroll/$place"
    cp "${photos[0]}" "$WORK/images/enroll/$place/000.${photos[0]##*.}"
    cp "${photos[1]}" "$WORK/images/enroll/$place/180.${photos[1]##*.}"
  else
    STRANGER_PHOTO=${photos[0]}
    break
  fi
done
# waymark-demo-data keeps the places not in the database in query/unknown.
if [ -z "$STRANGER_PHOTO" ] && [ -d "$SOURCE/../query/unknown" ]; then
  STRANGER_PHOTO=$(find "$SOURCE/../query/unknown" -type f \( -iname '*.jpg' -o -iname '*.png' \) | sort | head -1 || true)
fi
[ ${#PLACES[@]} -eq 5 ] && [ -n "$STRANGER_PHOTO" ] ||
  fail "$SOURCE needs 6 folders with 2 photos each (5 to enroll, 1 stranger)"
cp "$STRANGER_PHOTO" "$WORK/images/unknown/stranger.${STRANGER_PHOTO##*.}"
chmod -R a+rX "$WORK/images"
QUERY_PLACE=${PLACES[2]}
QUERY=$(cd "$WORK/images/enroll/$QUERY_PLACE" && ls 180.*)
STRANGER=$(cd "$WORK/images/unknown" && ls)
info "photos from $SOURCE: enroll ${PLACES[*]} (2 views each); $STRANGER_PHOTO is a stranger"

# ---- 2. engine -----------------------------------------------------------------------------------
if [ "$OWN_ENGINE" -eq 1 ]; then
  step "containerd + dockerd under $WORK"
  for path in "${HOST_PATHS[@]}"; do [ -e "$path" ] || CREATED_PATHS+=("$path"); done
  mkdir -p "$WORK/containerd" "$WORK/docker" "$WORK/exec"
  cat > "$WORK/containerd.toml" <<EOF
version = 2
root = "$WORK/containerd/root"
state = "$WORK/containerd/state"
disabled_plugins = ["io.containerd.grpc.v1.cri"]
[grpc]
  address = "$WORK/containerd.sock"
EOF
  # Our own daemon configuration, so a host /etc/docker/daemon.json cannot interfere, and the
  # daemon's identity key goes to $WORK instead of /etc/docker/key.json.
  printf '{ "deprecated-key-path": "%s/key.json" }\n' "$WORK" > "$WORK/daemon.json"
  containerd --config "$WORK/containerd.toml" > "$LOG_DIR/containerd.log" 2>&1 &
  CONTAINERD_PID=$!
  for ((i = 0; i < 100; i++)); do [ -S "$WORK/containerd.sock" ] && break; sleep 0.1; done
  [ -S "$WORK/containerd.sock" ] || { tail -20 "$LOG_DIR/containerd.log" >&2; fail "containerd did not start"; }
  dockerd --config-file "$WORK/daemon.json" --containerd "$WORK/containerd.sock" \
    --data-root "$WORK/docker" --exec-root "$WORK/exec" --pidfile "$WORK/dockerd.pid" \
    -H "unix://$WORK/docker.sock" --bridge=none --iptables=false --ip6tables=false \
    --ip-masq=false --userland-proxy=false > "$LOG_DIR/dockerd.log" 2>&1 &
  DOCKERD_PID=$!
  export DOCKER_HOST="unix://$WORK/docker.sock"
  for ((i = 0; i < 300; i++)); do
    docker info >/dev/null 2>&1 && break
    kill -0 "$DOCKERD_PID" 2>/dev/null || break
    sleep 0.1
  done
  docker info >/dev/null 2>&1 || { tail -20 "$LOG_DIR/dockerd.log" >&2; fail "dockerd did not start"; }
  info "dockerd $(docker version -f '{{.Server.Version}}'), storage driver $(docker info -f '{{.Driver}}'), cgroup $(docker info -f '{{.CgroupVersion}}')"
else
  export DOCKER_HOST=$WAYMARK_DOCKER_HOST
  docker info >/dev/null || fail "no engine at $DOCKER_HOST"
  info "using the engine at $DOCKER_HOST"
fi

# ---- 3. base image -------------------------------------------------------------------------------
PROXY=$(apt-config dump 2>/dev/null | sed -n 's/^Acquire::http::Proxy "\(.*\)";/\1/p' | head -1 || true)
if [ -n "$PROXY" ] && [ -z "${http_proxy:-}" ]; then export http_proxy=$PROXY; fi
if docker image inspect debian:bookworm >/dev/null 2>&1; then
  step "base image debian:bookworm (present)"
else
  step "base image debian:bookworm (debootstrap)"
  URIS=$(apt_uris)
  MIRROR=${WAYMARK_DEBIAN_MIRROR:-$(grep -E '/debian$' <<<"$URIS" | head -1 || true)}
  MIRROR=${MIRROR:-http://deb.debian.org/debian}
  SECURITY=$(grep -E '/debian-security$' <<<"$URIS" | head -1 || true)
  SECURITY=${SECURITY:-http://deb.debian.org/debian-security}
  if [ -n "${WAYMARK_BASE_TAR:-}" ] && [ -s "$WAYMARK_BASE_TAR" ]; then
    info "importing $WAYMARK_BASE_TAR"
    docker import --change 'CMD ["bash"]' "$WAYMARK_BASE_TAR" debian:bookworm >/dev/null
  else
    info "debootstrap --variant=minbase bookworm from $MIRROR"
    ROOTFS=$WORK/rootfs
    # One retry: a mirror hiccup should not fail CI.
    if ! debootstrap --variant=minbase bookworm "$ROOTFS" "$MIRROR" > "$LOG_DIR/debootstrap.log" 2>&1; then
      tail -5 "$LOG_DIR/debootstrap.log" | sed "s/^/$(stamp)    /"
      info "debootstrap failed; retrying once from scratch"
      unmount_under "$ROOTFS"
      rm -rf "$ROOTFS"
      debootstrap --variant=minbase bookworm "$ROOTFS" "$MIRROR" >> "$LOG_DIR/debootstrap.log" 2>&1 ||
        { tail -20 "$LOG_DIR/debootstrap.log" >&2; unmount_under "$ROOTFS"; fail "debootstrap (see $LOG_DIR/debootstrap.log)"; }
    fi
    unmount_under "$ROOTFS"
    # Like Debian's official image: deb822 sources with updates and security, no package caches.
    rm -f "$ROOTFS/etc/apt/sources.list"
    cat > "$ROOTFS/etc/apt/sources.list.d/debian.sources" <<EOF
Types: deb
URIs: $MIRROR
Suites: bookworm bookworm-updates
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg

Types: deb
URIs: $SECURITY
Suites: bookworm-security
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
EOF
    rm -rf "$ROOTFS"/var/lib/apt/lists/* "$ROOTFS"/var/cache/apt/*.bin "$ROOTFS"/var/cache/apt/archives/*.deb
    if [ -n "${WAYMARK_BASE_TAR:-}" ]; then
      tar -C "$ROOTFS" -cf "$WAYMARK_BASE_TAR" .
      docker import --change 'CMD ["bash"]' "$WAYMARK_BASE_TAR" debian:bookworm >/dev/null
    else
      tar -C "$ROOTFS" -c . | docker import --change 'CMD ["bash"]' - debian:bookworm >/dev/null
    fi
    rm -rf "$ROOTFS"
  fi
  info "debian:bookworm: $(docker run --rm --network host debian:bookworm sh -c '. /etc/os-release; echo $PRETTY_NAME')"
fi

# ---- 4. image ------------------------------------------------------------------------------------
step "docker build ($IMAGE, docker/Dockerfile)"
BUILD_ARGS=()
[ -z "${http_proxy:-}" ] || BUILD_ARGS+=(--build-arg "http_proxy=$http_proxy")
# build_image TAG DOCKERFILE CONTEXT. The build's exit status goes through a file: the pipe to the
# log filter would hide it.
build_image() {
  { docker build --network host "${BUILD_ARGS[@]}" -f "$2" -t "$1" "$3" &&
      echo 0 > "$WORK/build.rc" || echo $? > "$WORK/build.rc"; } 2>&1 |
    while IFS= read -r line; do
      printf '%(%H:%M:%S)T %s\n' -1 "$line" >> "$LOG_DIR/build.log"
      case $line in
        Step\ *) info "$line" ;;
        runtime\ packages:*) info "$line" ;;
        \[*/*\]\ Linking*) info "$line" ;;
      esac
    done
  build_rc=$(cat "$WORK/build.rc")
}
# A download that failed (mirror hiccup) gets one more try; the layers already built are cached.
build_with_retry() {
  build_image "$@"
  if [ "$build_rc" -ne 0 ] &&
     grep -qE 'Failed to fetch|Temporary failure resolving|Could not (connect|resolve)|Connection (timed out|refused|reset)|Hash Sum mismatch' \
       <<<"$(tail -60 "$LOG_DIR/build.log")"; then
    tail -5 "$LOG_DIR/build.log" | sed "s/^/$(stamp)    /"
    info "the build failed downloading packages; retrying once"
    build_image "$@"
  fi
  [ "$build_rc" -eq 0 ] || { tail -40 "$LOG_DIR/build.log" >&2; fail "docker build $1 (see $LOG_DIR/build.log)"; }
}
build_with_retry "$IMAGE" "$REPO/docker/Dockerfile" "$REPO"
info "image $IMAGE: $(docker image inspect -f '{{.Size}}' "$IMAGE" | awk '{printf "%.0f MB", $1 / 1e6}')"
PG_IMAGE=waymark-postgres:local
build_with_retry "$PG_IMAGE" "$REPO/docker/postgres/Dockerfile" "$REPO/docker/postgres"
info "image $PG_IMAGE: $(docker image inspect -f '{{.Size}}' "$PG_IMAGE" | awk '{printf "%.0f MB", $1 / 1e6}')"
check "runs as the non-root user waymark" \
  test "$(docker run --rm --entrypoint id "$IMAGE" -un)" = waymark

# ---- 5. compose: server ---------------------------------------------------------------------------
step "compose up server"
PORT=$(free_port)
METRICS_PORT=$(free_port)
export WAYMARK_PORT=$PORT WAYMARK_METRICS_LISTEN="127.0.0.1:$METRICS_PORT" WAYMARK_IMAGE=$IMAGE \
  WAYMARK_POSTGRES_IMAGE=$PG_IMAGE
compose config -q || fail "docker/compose.yaml does not parse"
compose up -d --no-build server 2>&1 | sed "s/^/$(stamp)    compose: /" || fail "compose up server"
info "server on 127.0.0.1:$PORT, metrics on 127.0.0.1:$METRICS_PORT"
wait_healthy 120
CID=$(server_cid)
FIRST_START=$(docker inspect -f '{{.State.StartedAt}}' "$CID")
check "tini is PID 1, waymark-server its child" \
  docker exec "$CID" sh -c 'grep -qx tini /proc/1/comm && grep -qx waymark-server /proc/[0-9]*/comm' 

step "tokens (docker exec waymark-server token create)"
# make_tokens CONTAINER [waymark-server options]: sets ADMIN_TOKEN, MAPPER_TOKEN and ROBOT_TOKEN
# (robot-1), made with the server's own command line inside the container.
make_tokens() {
  local cid=$1
  shift
  token() {
    local secret
    secret=$(docker exec "$cid" waymark-server "$@" 2>/dev/null) || fail "waymark-server $*"
    [[ "$secret" == wm_* ]] || fail "waymark-server $*: unexpected output"
    echo "$secret"
  }
  ADMIN_TOKEN=$(token "$@" token create smoke-admin --role admin)
  MAPPER_TOKEN=$(token "$@" token create smoke-mapper --role mapper)
  ROBOT_TOKEN=$(token "$@" token create smoke-robot --role robot --robot-id robot-1)
}
make_tokens "$CID" --db /var/lib/waymark/waymark.db
info "admin, mapper and robot (robot-1) tokens created"
check "token list shows them" sh -c \
  "docker exec $CID waymark-server --db /var/lib/waymark/waymark.db token list | grep -c smoke- | grep -qx 3"

# ---- 6. through the container ----------------------------------------------------------------------
step "auth, enroll and recognize through the container"
expect_error UNAUTHENTICATED "db list without a token" run_waymark -- db list
expect_error UNAUTHENTICATED "db list with a wrong token" \
  run_waymark -e WAYMARK_TOKEN=wm_not_a_token -- db list
check "health needs no token" run_waymark -- health
check "db create smoke (mapper)" as_mapper -- db create smoke
expect_error PERMISSION_DENIED "robot token cannot enroll" as_robot -- enroll smoke /images/enroll
out=$(as_mapper -- enroll smoke /images/enroll 2>&1) || { echo "$out" >&2; fail "enroll"; }
grep -q "10 views of 5 crossings into smoke: 10 stored" <<<"$out" || { echo "$out" >&2; fail "enroll: expected 10 views of 5 crossings, 10 stored"; }
info "ok: $(grep "views of" <<<"$out")"
expect_recognized as_robot "/images/enroll/$QUERY_PLACE/$QUERY" "$QUERY_PLACE" 180.0
expect_rejected as_robot "/images/unknown/$STRANGER"

step "example robot service (simulator, SLAM session)"
WAYMARK_ROBOT_TOKEN=$ROBOT_TOKEN WAYMARK_ROBOT_DURATION=20 WAYMARK_ROBOT_FLAGS="--sim-speed 4" \
  WAYMARK_ROBOT_SERVER="127.0.0.1:$PORT" compose up -d --no-build robot 2>&1 |
  sed "s/^/$(stamp)    compose: /" || fail "compose up robot"
ROBOT_CID=$(compose ps -q robot)
[ -n "$ROBOT_CID" ] || fail "no robot container"
ROBOT_EXIT=$(timeout 120 /usr/bin/docker wait "$ROBOT_CID") || fail "robot did not finish in 120 s"
docker logs "$ROBOT_CID" > "$LOG_DIR/robot.log" 2>&1
[ "$ROBOT_EXIT" = 0 ] || { tail -20 "$LOG_DIR/robot.log" >&2; fail "robot exited with $ROBOT_EXIT"; }
info "ok: robot ran and exited 0: $(grep -E 'scans=' "$LOG_DIR/robot.log" | tail -1 | tr -s ' ')"
SESSIONS=$(as_admin -- slam list 2>&1) || { echo "$SESSIONS" >&2; fail "slam list"; }
grep -q robot-1 <<<"$SESSIONS" || { echo "$SESSIONS" >&2; fail "no SLAM session of robot-1"; }
info "ok: slam list shows robot-1's session"

step "metrics"
metrics() {
  local body
  exec 3<>"/dev/tcp/127.0.0.1/$METRICS_PORT" || return 1
  printf 'GET /metrics HTTP/1.0\r\nHost: localhost\r\n\r\n' >&3
  body=$(cat <&3)
  exec 3<&-
  grep -q '^waymark_' <<<"$body"
}
check "GET /metrics answers with waymark_ series" metrics

# ---- 7. restart: data on the volume --------------------------------------------------------------
step "restart: the data survives on the volume"
compose restart server 2>&1 | sed "s/^/$(stamp)    compose: /" || fail "compose restart server"
[ "$(docker inspect -f '{{.State.StartedAt}}' "$CID")" != "$FIRST_START" ] || fail "server did not restart"
wait_healthy 120
check "the first run stopped gracefully (\"stopped\" logged)" sh -c "docker logs $CID 2>&1 | grep -q '\] stopped$'"
check "loaded 1 crossing database with 10 views" sh -c "docker logs $CID 2>&1 | grep -q 'loaded 1 crossing databases (10 views)'"
expect_recognized as_robot "/images/enroll/$QUERY_PLACE/$QUERY" "$QUERY_PLACE" 180.0
check "tokens survived (the robot token still works)" as_robot -- db list
SESSIONS=$(as_admin -- slam list 2>&1) && grep -q robot-1 <<<"$SESSIONS" || fail "robot-1's session is gone"
info "ok: robot-1's SLAM session is still listed"

# ---- 8. TLS on the same volume ----------------------------------------------------------------------
step "TLS: server re-created with a certificate, same volume"
(
  cd "$WORK/tls"
  openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj "/CN=waymark smoke CA" \
    -keyout ca.key -out ca.crt 2>/dev/null
  openssl req -newkey rsa:2048 -nodes -subj "/CN=waymark" -keyout server.key -out server.csr 2>/dev/null
  printf 'subjectAltName=DNS:localhost,IP:127.0.0.1\nbasicConstraints=CA:FALSE\nkeyUsage=digitalSignature,keyEncipherment\nextendedKeyUsage=serverAuth\n' > ext.cnf
  openssl x509 -req -in server.csr -CA ca.crt -CAkey ca.key -CAcreateserial -days 2 \
    -extfile ext.cnf -out server.crt 2>/dev/null
  rm -f ca.key ca.srl server.csr ext.cnf
  chown 10001:10001 server.key   # the image's user waymark
  chmod 600 server.key
  chmod 644 ca.crt server.crt
) || fail "openssl could not make the test certificates"
export WAYMARK_TLS_DIR=$WORK/tls WAYMARK_TLS_CERT=/etc/waymark/tls/server.crt \
  WAYMARK_TLS_KEY=/etc/waymark/tls/server.key WAYMARK_TLS_CA=/etc/waymark/tls/ca.crt
compose up -d --no-build server 2>&1 | sed "s/^/$(stamp)    compose: /" || fail "compose up server (TLS)"
[ "$(server_cid)" != "$CID" ] || fail "compose did not re-create the server with the TLS settings"
wait_healthy 120
CID=$(server_cid)
check "the server says it serves TLS" sh -c "docker logs $CID 2>&1 | grep -q 'TLS on '"
check "health over TLS (the container's own check)" docker exec "$CID" waymark health
expect_recognized as_robot "/images/enroll/$QUERY_PLACE/$QUERY" "$QUERY_PLACE" 180.0 -e WAYMARK_TLS_CA=/tls/ca.crt
expect_error 'UNAVAILABLE\|DEADLINE_EXCEEDED' "a plaintext client is refused" as_robot -- --timeout 5 db list
unset WAYMARK_TLS_DIR WAYMARK_TLS_CERT WAYMARK_TLS_KEY WAYMARK_TLS_CA

# ---- 9. graceful stop ---------------------------------------------------------------------------------
step "docker stop is graceful"
STOP_START=$SECONDS
compose stop server 2>&1 | sed "s/^/$(stamp)    compose: /" || fail "compose stop server"
EXIT_CODE=$(docker inspect -f '{{.State.ExitCode}}' "$CID")
[ "$EXIT_CODE" = 0 ] || { docker logs --tail 20 "$CID" >&2; fail "server exit code $EXIT_CODE after docker stop (137 = killed)"; }
check "exit code 0 and \"stopped\" logged, in $((SECONDS - STOP_START)) s" \
  sh -c "docker logs $CID 2>&1 | tail -3 | grep -q '\] stopped$'"

# ---- 10. scale-out: PostgreSQL and three servers -------------------------------------------------
step "fleet: PostgreSQL 15 and three servers (--profile fleet)"
PG_PORT=$(free_port)
FLEET_PORTS=("$(free_port)" "$(free_port)" "$(free_port)")
export WAYMARK_PG_PORT=$PG_PORT WAYMARK_PG_PASSWORD="smoke-$(openssl rand -hex 12)" \
  WAYMARK_FLEET_PORT_1=${FLEET_PORTS[0]} WAYMARK_FLEET_PORT_2=${FLEET_PORTS[1]} \
  WAYMARK_FLEET_PORT_3=${FLEET_PORTS[2]} WAYMARK_FLEET_METRICS_1=$(free_port) \
  WAYMARK_FLEET_METRICS_2=$(free_port) WAYMARK_FLEET_METRICS_3=$(free_port) \
  WAYMARK_FLEET_FLAGS="--session-lease-seconds 5 --slam-checkpoint-seconds 2"
FLEET_ADDRESSES=("127.0.0.1:${FLEET_PORTS[0]}" "127.0.0.1:${FLEET_PORTS[1]}" "127.0.0.1:${FLEET_PORTS[2]}")
FLEET_LIST=$(IFS=,; echo "${FLEET_ADDRESSES[*]}")
compose up -d --no-build fleet-1 fleet-2 fleet-3 2>&1 | sed "s/^/$(stamp)    compose: /" ||
  fail "compose up fleet-1 fleet-2 fleet-3"
info "PostgreSQL on 127.0.0.1:$PG_PORT, servers on $FLEET_LIST"
wait_healthy 60 postgres
for n in 1 2 3; do wait_healthy 120 "fleet-$n"; done
check "the servers use PostgreSQL (\"postgresql://waymark@...\" logged, no password)" sh -c \
  "docker logs $(server_cid fleet-1) 2>&1 | grep -q 'postgresql://waymark@127.0.0.1:$PG_PORT/waymark' &&
   ! docker logs $(server_cid fleet-1) 2>&1 | grep -qF '$WAYMARK_PG_PASSWORD'"

make_tokens "$(server_cid fleet-1)"  # the container's WAYMARK_DB: the fleet's database
info "admin, mapper and robot (robot-1) tokens created in the fleet's database (exec fleet-1)"

step "fleet: enroll on one server, recognize on the others"
TARGET=${FLEET_ADDRESSES[0]} check "db create smoke on fleet-1" as_mapper -- db create smoke
out=$(TARGET=${FLEET_ADDRESSES[0]} as_mapper -- enroll smoke /images/enroll 2>&1) || { echo "$out" >&2; fail "enroll on fleet-1"; }
grep -q "10 views of 5 crossings into smoke: 10 stored" <<<"$out" || { echo "$out" >&2; fail "enroll on fleet-1: expected 10 stored"; }
ENROLLED=$SECONDS
info "ok: fleet-1: $(grep "views of" <<<"$out")"
# docs/scale-out.md: visible elsewhere within milliseconds (a notification), at most the 5 s sync.
until out=$(TARGET=${FLEET_ADDRESSES[1]} as_robot -- --json recognize smoke "/images/enroll/$QUERY_PLACE/$QUERY" 2>&1) &&
      grep -q '"recognized": true' <<<"$out"; do
  [ $((SECONDS - ENROLLED)) -le 6 ] || { echo "$out" | head -30 >&2; fail "fleet-2 does not recognize what fleet-1 enrolled"; }
  sleep 0.5
done
TARGET=${FLEET_ADDRESSES[1]} expect_recognized as_robot "/images/enroll/$QUERY_PLACE/$QUERY" "$QUERY_PLACE" 180.0
TARGET=${FLEET_ADDRESSES[2]} expect_recognized as_robot "/images/enroll/$QUERY_PLACE/$QUERY" "$QUERY_PLACE" 180.0
TARGET=$FLEET_LIST expect_rejected as_robot "/images/unknown/$STRANGER"

step "fleet: the server serving a SLAM session dies, the session goes on"
# slam_state: "SESSION SERVED_BY SCANS" of robot-1's open session, asked of server $1.
slam_state() {
  local json
  json=$(TARGET=$1 as_admin -- --json slam list --robot robot-1 2>/dev/null) || return 0
  field() { grep -oE "\"$1\": (\"[^\"]*\"|[0-9]+)" <<<"$json" | head -1 | cut -d' ' -f2- | tr -d '"'; }
  [ "$(grep -c '"session_id"' <<<"$json")" -eq 1 ] && [ "$(field state)" = open ] &&
    [ -n "$(field served_by)" ] && echo "$(field session_id) $(field served_by) $(field scans_processed)"
  return 0
}
WAYMARK_ROBOT_TOKEN=$ROBOT_TOKEN WAYMARK_ROBOT_DURATION=240 WAYMARK_ROBOT_FLAGS="--sim-speed 4" \
  WAYMARK_ROBOT_SERVER=$FLEET_LIST compose up -d --no-build fleet-robot 2>&1 |
  sed "s/^/$(stamp)    compose: /" || fail "compose up fleet-robot"
ROBOT_CID=$(compose ps -q fleet-robot)
[ -n "$ROBOT_CID" ] || fail "no fleet-robot container"
STATE=""
for ((i = 0; i < 60; i++)); do
  STATE=$(slam_state "${FLEET_ADDRESSES[0]}")
  [ -n "$STATE" ] && [ "$(cut -d' ' -f3 <<<"$STATE")" -ge 20 ] && break
  sleep 1
done
[ -n "$STATE" ] || { docker logs --tail 20 "$ROBOT_CID" >&2; fail "no open session of robot-1 served by a fleet server"; }
read -r SESSION OWNER SCANS_BEFORE <<<"$STATE"
OWNER_SERVICE=""
for n in 0 1 2; do [ "${FLEET_ADDRESSES[$n]}" = "$OWNER" ] && OWNER_SERVICE=fleet-$((n + 1)) && SURVIVOR=${FLEET_ADDRESSES[$(((n + 1) % 3))]}; done
[ -n "$OWNER_SERVICE" ] || fail "session $SESSION is served by $OWNER, not one of $FLEET_LIST"
info "session $SESSION served by $OWNER ($OWNER_SERVICE), $SCANS_BEFORE scans"
docker kill "$(server_cid "$OWNER_SERVICE")" > /dev/null
KILLED=$SECONDS
info "SIGKILLed $OWNER_SERVICE"
MOVED=""
while [ $((SECONDS - KILLED)) -le 60 ]; do
  STATE=$(slam_state "$SURVIVOR")
  read -r S NEW_OWNER SCANS <<<"${STATE:-none none 0}"
  if [ "$S" = "$SESSION" ] && [ "$NEW_OWNER" != "$OWNER" ] && [ "$SCANS" -gt "$SCANS_BEFORE" ]; then
    MOVED=1; break
  fi
  sleep 0.5
done
[ -n "$MOVED" ] || { docker logs --tail 30 "$ROBOT_CID" >&2; fail "session $SESSION did not go on on another server within 60 s (last: ${STATE:-none})"; }
info "ok: session $SESSION goes on on $NEW_OWNER after $((SECONDS - KILLED)) s ($SCANS scans; lease 5 s)"
ROBOT_EXIT=$(timeout 240 /usr/bin/docker wait "$ROBOT_CID") || fail "fleet robot did not finish in 240 s"
docker logs "$ROBOT_CID" > "$LOG_DIR/fleet-robot.log" 2>&1
[ "$ROBOT_EXIT" = 0 ] || { tail -20 "$LOG_DIR/fleet-robot.log" >&2; fail "fleet robot exited with $ROBOT_EXIT"; }
LAST=$(grep -E '^stopped: session' "$LOG_DIR/fleet-robot.log" | tail -1)
grep -q "^stopped: session $SESSION (closed)" <<<"$LAST" ||
  { tail -20 "$LOG_DIR/fleet-robot.log" >&2; fail "the robot did not end its own session $SESSION: $LAST"; }
[ "$(grep -oE '[0-9]+ reconnects' <<<"$LAST" | cut -d' ' -f1)" -ge 1 ] ||
  fail "the robot did not reconnect: $LAST"
info "ok: robot exited 0: $LAST"
SESSIONS=$(TARGET=$SURVIVOR as_admin -- --json slam list --robot robot-1 2>&1) || { echo "$SESSIONS" >&2; fail "slam list"; }
[ "$(grep -c '"session_id"' <<<"$SESSIONS")" -eq 1 ] ||
  { echo "$SESSIONS" >&2; fail "robot-1 has more than its one session"; }
info "ok: robot-1 has exactly one session"

end_step

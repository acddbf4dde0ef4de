#!/usr/bin/env bash
# The PostgreSQL server the test suite runs its PostgreSQL tests against (issue 19): Debian's
# postgresql-15 binaries, a cluster of its own made by initdb in a temporary directory, on a free
# loopback port, run as an unprivileged user (postgres refuses to run as root), stopped at the end.
# ctest runs `start` before and `stop` after every test that needs it (FIXTURES_SETUP/CLEANUP in
# tests/CMakeLists.txt); tests read the server's address from STATE_DIR/uri.
#
#   tests/support/postgres_server.sh start STATE_DIR
#   tests/support/postgres_server.sh stop STATE_DIR
#   tests/support/postgres_server.sh restart|pause|resume STATE_DIR
#                                        (the same cluster and port: tests of reconnecting)
#
# Without the binaries, `start` says so, writes no uri, and exits 0: the tests then skip with that
# message (scripts/install-deps.sh installs postgresql-15, so CI always has them).
set -euo pipefail

usage() { echo "usage: $0 start|stop|restart|pause|resume STATE_DIR" >&2; exit 2; }
[ $# -eq 2 ] || usage
ACTION=$1
STATE=$2

pg_bin() {
  local dir
  for dir in /usr/lib/postgresql/*/bin; do
    [ -x "$dir/initdb" ] && [ -x "$dir/pg_ctl" ] && echo "$dir"
  done | sort -V | tail -n 1
}

# Runs a command as the unprivileged user that owns the cluster.
as_owner() {
  if [ "$(id -u)" -eq 0 ]; then runuser -u postgres -- "$@"; else "$@"; fi
}

stop() {
  [ -f "$STATE/data_dir" ] || { rm -f "$STATE/uri"; return 0; }
  local data bin
  data=$(cat "$STATE/data_dir")
  bin=$(pg_bin)
  if [ -n "$bin" ] && [ -f "$data/cluster/postmaster.pid" ]; then
    as_owner "$bin/pg_ctl" -D "$data/cluster" -m immediate -w stop >/dev/null 2>&1 || true
  fi
  rm -rf "$data"
  rm -f "$STATE/uri" "$STATE/data_dir" "$STATE/options"
}

start() {
  mkdir -p "$STATE"
  stop  # a server left over by an interrupted run
  local bin
  bin=$(pg_bin)
  if [ -z "$bin" ]; then
    echo "postgres_server: no PostgreSQL server binaries under /usr/lib/postgresql/*/bin" \
         "(Debian package postgresql-15; scripts/install-deps.sh installs it):" \
         "the PostgreSQL tests will skip" >&2
    return 0
  fi
  if [ "$(id -u)" -eq 0 ] && ! id postgres >/dev/null 2>&1; then
    echo "postgres_server: running as root but there is no 'postgres' user to run the server as" \
         "(the postgresql-15 package creates it): the PostgreSQL tests will skip" >&2
    return 0
  fi
  local data
  data=$(mktemp -d /tmp/waymark-pgtest.XXXXXX)
  chmod 700 "$data"
  [ "$(id -u)" -eq 0 ] && chown postgres: "$data"
  echo "$data" > "$STATE/data_dir"
  # Trust authentication on loopback only: a throwaway cluster for tests. fsync off: nothing here
  # must survive a power loss, and the suite runs on slow shared disks.
  # --no-locale: a minimal machine (CI) may set LANG to a locale it has not generated.
  as_owner "$bin/initdb" -D "$data/cluster" -U waymark -A trust -E UTF8 --no-locale --no-sync \
    >"$data/initdb.log" 2>&1 || { cat "$data/initdb.log" >&2; exit 1; }
  local port tries=0
  while :; do
    port=$(( 20000 + RANDOM % 20000 ))
    echo "-p $port -k $data -c listen_addresses=127.0.0.1 -c fsync=off -c synchronous_commit=off \
-c full_page_writes=off -c max_connections=300" > "$STATE/options"
    if as_owner "$bin/pg_ctl" -D "$data/cluster" -l "$data/server.log" -w -t 60 \
         -o "$(cat "$STATE/options")" start >/dev/null 2>&1; then
      break
    fi
    tries=$((tries + 1))
    if [ $tries -ge 5 ]; then
      echo "postgres_server: the server did not start; its log:" >&2
      cat "$data/server.log" >&2 || true
      exit 1
    fi
  done
  echo "postgresql://waymark@127.0.0.1:$port/postgres" > "$STATE/uri"
  echo "postgres_server: PostgreSQL $("$bin/postgres" --version | awk '{print $3}') on" \
       "127.0.0.1:$port, cluster in $data"
}

# The same cluster on the same port, for tests of a server that goes away and comes back.
restart() { pause; resume; }
pause() {
  as_owner "$(pg_bin)/pg_ctl" -D "$(cat "$STATE/data_dir")/cluster" -m fast -w -t 60 stop >/dev/null
}
resume() {
  local data
  data=$(cat "$STATE/data_dir")
  as_owner "$(pg_bin)/pg_ctl" -D "$data/cluster" -l "$data/server.log" -w -t 60 \
    -o "$(cat "$STATE/options")" start >/dev/null
}

case "$ACTION" in
  start) start ;;
  stop) stop ;;
  restart) restart ;;
  pause) pause ;;
  resume) resume ;;
  *) usage ;;
esac

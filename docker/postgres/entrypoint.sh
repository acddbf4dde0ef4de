#!/bin/sh
# The fleet's database server: on first start it makes the cluster in $PGDATA, the role `waymark`
# (password $WAYMARK_PG_PASSWORD, never printed) and its database `waymark`; then it runs postgres
# in the foreground on $WAYMARK_PG_LISTEN:$WAYMARK_PG_PORT. $WAYMARK_PG_FLAGS and extra arguments
# go to postgres (e.g. -c max_connections=200).
set -eu
: "${PGDATA:=/var/lib/postgresql/data}"
: "${WAYMARK_PG_PORT:=5432}"
: "${WAYMARK_PG_LISTEN:=127.0.0.1}"
if [ -z "${WAYMARK_PG_PASSWORD:-}" ]; then
  echo "waymark-postgres: set WAYMARK_PG_PASSWORD (the servers get the same value as PGPASSWORD)" >&2
  exit 2
fi

if [ ! -s "$PGDATA/PG_VERSION" ]; then
  echo "waymark-postgres: new cluster in $PGDATA"
  # Local socket connections are this container's postgres user only (peer); TCP needs the password.
  initdb -D "$PGDATA" --no-locale -E UTF8 -U postgres --auth-local=peer --auth-host=scram-sha-256 >/dev/null
  pg_ctl -D "$PGDATA" -w -s -o "-c listen_addresses='' -k /tmp" start
  # The password comes from the environment (\getenv, not a command line) through psql's
  # literal quoting (:'pw'), so any character is safe.
  psql -h /tmp -U postgres -d postgres -v ON_ERROR_STOP=1 -q <<'SQL'
\getenv pw WAYMARK_PG_PASSWORD
CREATE ROLE waymark LOGIN PASSWORD :'pw';
CREATE DATABASE waymark OWNER waymark;
SQL
  pg_ctl -D "$PGDATA" -w -s -m fast stop
  echo "waymark-postgres: role and database waymark created"
fi
exec postgres -D "$PGDATA" -c listen_addresses="$WAYMARK_PG_LISTEN" -p "$WAYMARK_PG_PORT" \
  -k /tmp ${WAYMARK_PG_FLAGS:-} "$@"

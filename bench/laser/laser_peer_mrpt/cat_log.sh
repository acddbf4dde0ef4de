#!/usr/bin/env bash
# Writes a CARMEN log to stdout, decompressing .bz2 and .gz by the file name.
set -euo pipefail
case "$1" in
  *.bz2) exec bzip2 -dc "$1" ;;
  *.gz) exec gzip -dc "$1" ;;
  *) exec cat "$1" ;;
esac

#!/bin/sh
# Issue 35: every answer the services give to the request targets' inputs (their seeds, the files
# of corpus/<target>/ and mutated inputs) must parse with a strict parser in another language:
# Python's protobuf refuses a proto3 string that is not valid UTF-8, and with it the whole answer.
# waymark-fuzz --answers writes the answers (responses, stream updates, status messages), then
# parse_answers.py parses each one.
#
#   answers_utf8_test.sh WAYMARK_FUZZ CORPUS_DIR RUNS
#
# Exit 77 (ctest: skipped) when Python has no protobuf (Debian's python3-protobuf, which
# scripts/install-deps.sh installs).
set -eu
fuzz=$1
corpus=$2
runs=$3
here=$(cd "$(dirname "$0")" && pwd)
# Debian's python3-protobuf is for the system's Python, which another python3 on the PATH (pyenv,
# a virtualenv) may hide: the first of them that has protobuf.
python=""
for candidate in /usr/bin/python3 python3; do
  if "$candidate" -c 'import google.protobuf' 2>/dev/null; then
    python=$candidate
    break
  fi
done
if [ -z "$python" ]; then
  echo "skipped: no python3 with protobuf (apt-get install python3-protobuf, or scripts/install-deps.sh)"
  exit 77
fi
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
for target in crossing_requests slam_requests token_requests; do
  # In the temporary folder: a crash leaves its fuzz-crash-<target> there, as ctest's runs do.
  (cd "$dir" && "$fuzz" --target "$target" --corpus "$corpus/$target" --runs "$runs" \
      --answers "$dir/$target.answers")
done
"$python" "$here/parse_answers.py" "$dir/crossing_requests.answers" "$dir/slam_requests.answers" \
  "$dir/token_requests.answers"

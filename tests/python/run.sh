#!/bin/sh
# Runs one unittest class of client_test.py (tests/python/CMakeLists.txt sets the environment)
# with the Python that has Debian's grpcio: another python3 on the PATH (pyenv, a virtualenv)
# may hide the system's. Exit 77 (ctest: skipped) when no Python has grpc.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
python=""
for candidate in /usr/bin/python3 python3; do
  if "$candidate" -c 'import grpc, google.protobuf' 2>/dev/null; then
    python=$candidate
    break
  fi
done
if [ -z "$python" ]; then
  echo "skipped: no python3 with grpc (apt-get install python3-grpcio, or scripts/install-deps.sh)"
  exit 77
fi
export PYTHONPATH="$WAYMARK_SOURCE_DIR/python:$WAYMARK_PYTHON_DIR${PYTHONPATH:+:$PYTHONPATH}"
export PYTHONDONTWRITEBYTECODE=1  # no __pycache__ in the source tree
cd "$here"
exec "$python" -m unittest -v "client_test.$1"

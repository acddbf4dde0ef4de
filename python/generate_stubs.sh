#!/bin/sh
# Generates the Python stubs of the Waymark API (proto/waymark/v1/*.proto) and of the gRPC health
# service with protoc and Debian's grpc_python_plugin (package protobuf-compiler-grpc), into
# OUT_DIR/waymark/v1/ and OUT_DIR/waymark/_health/grpc/health/v1/. The CMake target
# waymark_python runs it into build/python; without CMake:
#
#   python/generate_stubs.sh OUT_DIR
#   PYTHONPATH=python:OUT_DIR python3 -c 'import waymark'
#
# The health stub goes under waymark/_health/ because its proto path (grpc/health/v1/) would
# otherwise make a package named `grpc` that hides grpcio's. Its messages are generated here; the
# client calls the service by name (waymark/health.py), so the grpc plugin is not run on it.
# PROTOC and GRPC_PYTHON_PLUGIN override the programs found on the PATH.
set -eu
if [ $# -ne 1 ]; then
  echo "usage: $0 OUT_DIR" >&2
  exit 2
fi
out=$1
here=$(cd "$(dirname "$0")" && pwd)
proto_root=$here/../proto
protoc=${PROTOC:-protoc}
plugin=${GRPC_PYTHON_PLUGIN:-$(command -v grpc_python_plugin || true)}
if [ -z "$plugin" ]; then
  echo "$0: grpc_python_plugin not found (Debian: apt-get install protobuf-compiler-grpc)" >&2
  exit 1
fi
mkdir -p "$out/waymark/_health"
"$protoc" --proto_path="$proto_root" --python_out="$out" --grpc_python_out="$out" \
  --plugin=protoc-gen-grpc_python="$plugin" \
  "$proto_root"/waymark/v1/common.proto "$proto_root"/waymark/v1/crossing.proto \
  "$proto_root"/waymark/v1/slam.proto "$proto_root"/waymark/v1/token.proto
"$protoc" --proto_path="$proto_root" --python_out="$out/waymark/_health" \
  "$proto_root"/grpc/health/v1/health.proto

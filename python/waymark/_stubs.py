"""The generated stubs, with a message that says how to get them when they are missing.

They are not in the source tree: the CMake target waymark_python generates them into
build/python (python/generate_stubs.sh does it without CMake), and waymark/__init__.py finds
them on the PYTHONPATH (python/README.md).
"""
try:
    import grpc  # noqa: F401
except ImportError as e:  # pragma: no cover - depends on the machine
    raise ImportError(
        "waymark needs gRPC for Python: apt-get install python3-grpcio (Debian), or "
        "scripts/install-deps.sh") from e

try:
    from waymark.v1 import common_pb2  # noqa: F401
    from waymark.v1 import crossing_pb2, crossing_pb2_grpc  # noqa: F401
    from waymark.v1 import slam_pb2, slam_pb2_grpc  # noqa: F401
    from waymark.v1 import token_pb2, token_pb2_grpc  # noqa: F401
    from waymark._health.grpc.health.v1 import health_pb2  # noqa: F401
except ImportError as e:
    raise ImportError(
        "waymark: the generated stubs (waymark.v1) are not on the PYTHONPATH. Build them with "
        "`cmake --build build --target waymark_python` and run with "
        "PYTHONPATH=python:build/python, or generate them with python/generate_stubs.sh OUT_DIR "
        f"and add OUT_DIR ({e})") from e

__all__ = ["common_pb2", "crossing_pb2", "crossing_pb2_grpc", "slam_pb2", "slam_pb2_grpc",
           "token_pb2", "token_pb2_grpc", "health_pb2"]

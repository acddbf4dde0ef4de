"""Waymark's Python client: typed helpers over the generated gRPC stubs.

    import waymark
    client = waymark.connect("127.0.0.1:50051", token=None)
    print(client.list_databases())
    answer = client.recognize("city", "photo.jpg")
    print(answer.accepted, answer.crossing, answer.heading_deg)

The stubs are generated, not committed: `cmake --build build --target waymark_python` writes them
to build/python, and PYTHONPATH=python:build/python puts both halves of the package on the path
(python/README.md). Needs Debian's python3-grpcio and python3-protobuf only.
"""
import pkgutil

# The generated waymark.v1 lives in another directory of the PYTHONPATH (build/python/waymark):
# one package over both directories.
__path__ = pkgutil.extend_path(__path__, __name__)

from waymark.errors import Error  # noqa: E402
from waymark.retry import RetryOptions  # noqa: E402
from waymark.typed import (Candidate, CreatedToken, Crossing, Database, EnrollResult,  # noqa: E402
                           Frame, OccupancyGrid, Odometry, Pose2D, Pose3D, Recognition, Rejection,
                           Scan, SegmentMap, Session, SlamUpdate, Token, Trajectory,
                           TrajectoryPose)
from waymark.client import Client, connect  # noqa: E402

__all__ = [
    "connect", "Client", "Error", "RetryOptions", "Candidate", "CreatedToken", "Crossing",
    "Database", "EnrollResult", "Frame", "OccupancyGrid", "Odometry", "Pose2D", "Pose3D",
    "Recognition", "Rejection", "Scan", "SegmentMap", "Session", "SlamUpdate", "Token",
    "Trajectory", "TrajectoryPose",
]

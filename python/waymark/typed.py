"""Typed results and inputs. Each result keeps the whole answer in `raw` (the generated message),
so a field the dataclass leaves out is still one attribute away."""
import dataclasses
import math
import typing

import grpc

from waymark._stubs import crossing_pb2, slam_pb2, token_pb2

_CODES = {c.value[0]: c for c in grpc.StatusCode}


def status_code(number):
    """The grpc.StatusCode of a google.rpc.Code number (UNKNOWN when out of range)."""
    return _CODES.get(number, grpc.StatusCode.UNKNOWN)


def _heading(value, unknown=False):
    return None if unknown or math.isnan(value) else value


@dataclasses.dataclass
class Pose2D:
    x: float
    y: float
    theta: float

    @classmethod
    def of(cls, p):
        return cls(p.x, p.y, p.theta)


@dataclasses.dataclass
class Pose3D:
    x: float
    y: float
    z: float
    qx: float
    qy: float
    qz: float
    qw: float

    @classmethod
    def of(cls, p):
        return cls(p.x, p.y, p.z, p.qx, p.qy, p.qz, p.qw)


# --- crossings -------------------------------------------------------------------------------

@dataclasses.dataclass
class Database:
    name: str
    id: int
    crossings: int
    views: int
    clusters: int
    created_at: float
    raw: typing.Any = dataclasses.field(repr=False)

    @classmethod
    def of(cls, d):
        return cls(d.name, d.id, d.crossings, d.views, d.clusters, d.created_at, d)


@dataclasses.dataclass
class Crossing:
    name: str
    id: int
    label: str
    views: int

    @classmethod
    def of(cls, c):
        return cls(c.name, c.id, c.label, c.views)


_OUTCOMES = {crossing_pb2.ENROLL_OUTCOME_STORED: "stored",
             crossing_pb2.ENROLL_OUTCOME_DUPLICATE: "duplicate",
             crossing_pb2.ENROLL_OUTCOME_INVALID: "invalid"}


@dataclasses.dataclass
class EnrollResult:
    """One enrolled view: outcome "stored", "duplicate" (view_id names the stored view holding
    the same image) or "invalid" (streams with skip_invalid; error says why)."""
    outcome: str
    view_id: int
    crossing: str
    crossing_id: int
    heading_deg: typing.Optional[float]  # None: the view has no heading
    position: str
    keypoints: int
    cluster_id: int
    new_cluster: bool
    crossing_created: bool
    replaced_view_ids: typing.List[int]
    error: str
    raw: typing.Any = dataclasses.field(repr=False)

    @classmethod
    def of(cls, r):
        return cls(_OUTCOMES.get(r.outcome, "unspecified"), r.view_id, r.crossing, r.crossing_id,
                   _heading(r.heading_deg, r.heading_unknown), r.position, r.keypoints,
                   r.cluster_id, r.new_cluster, r.crossing_created, list(r.replaced_view_ids),
                   r.error_message, r)


@dataclasses.dataclass
class Candidate:
    crossing: str
    view_id: int
    heading_deg: typing.Optional[float]
    position: str
    matches: int
    similarity: float
    decision: float
    kept: bool
    log10_nfa: float

    @classmethod
    def of(cls, c):
        return cls(c.crossing, c.view_id, _heading(c.heading_deg), c.position, c.matches,
                   c.similarity, c.decision, c.kept, c.log10_nfa)


_MODES = {crossing_pb2.RECOGNITION_MODE_PAPER: "paper",
          crossing_pb2.RECOGNITION_MODE_VERIFIED: "verified",
          crossing_pb2.RECOGNITION_MODE_RETRIEVAL: "retrieval"}
MODES = {name: number for number, name in _MODES.items()}


@dataclasses.dataclass
class Recognition:
    """Which crossing the image shows and which way the camera faced.

    accepted: the server recognized a crossing; accepted_by names the path that accepted it
    ("nfa", "global", "stream_evidence", "decision", "inliers", "global_lift") or is "refused",
    and then `reason` says why. heading_deg is None when the view it matched has no heading.
    """
    accepted: bool
    crossing: str
    crossing_id: int
    heading_deg: typing.Optional[float]
    view_id: int
    position: str
    accepted_by: str
    reason: str
    mode: str
    decision: float
    log10_nfa: typing.Optional[float]  # None when not computed (no geometric match set)
    keypoints: int
    global_stage_skipped: str
    total_ms: float
    candidates: typing.List[Candidate] = dataclasses.field(repr=False)
    raw: typing.Any = dataclasses.field(repr=False)

    @classmethod
    def of(cls, r):
        return cls(r.recognized, r.crossing, r.crossing_id,
                   _heading(r.heading_deg) if r.recognized else None, r.view_id, r.position,
                   r.accepted_by, r.reason, _MODES.get(r.mode, "unspecified"), r.decision,
                   r.log10_nfa if r.nfa_computed else None, r.keypoints, r.global_stage_skipped,
                   r.timings.total_ms, [Candidate.of(c) for c in r.candidates], r)


# --- SLAM ------------------------------------------------------------------------------------

_STATES = {slam_pb2.Session.OPEN: "open", slam_pb2.Session.CLOSED: "closed"}


@dataclasses.dataclass
class Session:
    session_id: str
    robot_id: str
    name: str
    kind: str   # "laser" or "visual"
    state: str  # "open" or "closed"
    scans_processed: int  # visual sessions: frames
    segments: int
    map_revision: int
    messages_rejected: int
    raw: typing.Any = dataclasses.field(repr=False)

    @classmethod
    def of(cls, s):
        return cls(s.session_id, s.robot_id, s.name, s.kind, _STATES.get(s.state, "unspecified"),
                   s.scans_processed, s.segments, s.map_revision, s.messages_rejected, s)


@dataclasses.dataclass
class Rejection:
    """A message the session did not process (out of order, malformed, queue full)."""
    code: grpc.StatusCode
    message: str


@dataclasses.dataclass
class SlamUpdate:
    """A session's answer to one scan (laser) or frame (visual), or a rejection of any message
    (then `rejection` is set and the rest is empty)."""
    sequence: int
    rejection: typing.Optional[Rejection]
    stamp: float
    pose: typing.Optional[Pose2D]       # laser sessions
    covariance: typing.List[float]      # 3x3 of (x, y, theta), row-major
    pose3d: typing.Optional[Pose3D]     # visual sessions
    tracking: str                       # visual sessions: INITIALIZING, TRACKING or LOST
    scans_processed: int
    segments: int
    map_revision: int
    skipped: bool
    loop_closures: int
    graph_revision: int
    raw: typing.Any = dataclasses.field(repr=False)

    @classmethod
    def of(cls, u):
        rejection = None
        if u.HasField("rejection"):
            rejection = Rejection(status_code(u.rejection.code), u.rejection.message)
        tracking = ""
        if u.HasField("visual"):
            tracking = slam_pb2.VisualFrameInfo.TrackingState.Name(u.visual.state)
        return cls(u.sequence, rejection, u.stamp,
                   Pose2D.of(u.pose) if u.HasField("pose") else None, list(u.covariance),
                   Pose3D.of(u.pose3d) if u.HasField("pose3d") else None, tracking,
                   u.scans_processed, u.segments, u.map_revision, u.skipped, u.loop_closures,
                   u.graph_revision, u)


@dataclasses.dataclass
class TrajectoryPose:
    stamp: float
    pose: typing.Optional[Pose2D]    # laser sessions
    pose3d: typing.Optional[Pose3D]  # visual sessions


@dataclasses.dataclass
class Trajectory:
    session_id: str
    poses: typing.List[TrajectoryPose]
    raw: typing.Any = dataclasses.field(repr=False)

    @classmethod
    def of(cls, t):
        return cls(t.session_id,
                   [TrajectoryPose(p.stamp, Pose2D.of(p.pose) if p.HasField("pose") else None,
                                   Pose3D.of(p.pose3d) if p.HasField("pose3d") else None)
                    for p in t.poses], t)


@dataclasses.dataclass
class SegmentMap:
    session_id: str
    map_revision: int
    segments: int
    graph_nodes: int
    pruned_nodes: int  # of graph_nodes, pruned: their submaps added nothing the map held
    loop_closures: int
    consistent: typing.Optional[bool]  # the map's self-check; None when not checked
    raw: typing.Any = dataclasses.field(repr=False)

    @classmethod
    def of(cls, m):
        consistent = m.self_check.consistent if m.HasField("self_check") else None
        return cls(m.session_id, m.map_revision, len(m.segments), m.graph_nodes,
                   m.pruned_nodes, m.loop_closures, consistent, m)


@dataclasses.dataclass
class OccupancyGrid:
    """ROS's convention: row-major from the cell at `origin` (its lower-left corner, map frame),
    x right, y up; a cell is -1 unknown, 0 free ... 100 occupied."""
    session_id: str
    map_revision: int
    resolution: float
    origin: Pose2D
    width: int
    height: int
    cells: bytes
    scans: int
    raw: typing.Any = dataclasses.field(repr=False)

    @classmethod
    def of(cls, g):
        return cls(g.session_id, g.map_revision, g.resolution, Pose2D.of(g.origin), g.width,
                   g.height, g.cells, g.scans, g)

    def value(self, column, row):
        """The cell at (column, row) as a signed value: -1 unknown, 0..100."""
        byte = self.cells[row * self.width + column]
        return byte - 256 if byte > 127 else byte

    def counts(self):
        """(unknown, free, occupied) cell counts; occupied = 50 or more."""
        unknown = free = occupied = 0
        for byte in self.cells:
            v = byte - 256 if byte > 127 else byte
            if v < 0:
                unknown += 1
            elif v >= 50:
                occupied += 1
            else:
                free += 1
        return unknown, free, occupied


# --- sensor data a client sends --------------------------------------------------------------

@dataclasses.dataclass
class Odometry:
    """Cumulative wheel-odometry pose of the robot at `stamp` (laser sessions)."""
    stamp: float
    x: float
    y: float
    theta: float


@dataclasses.dataclass
class Scan:
    """One laser scan (m per beam; NaN, inf, <= 0: no return). The geometry fields left None
    take the session's."""
    stamp: float
    ranges: typing.Sequence[float]
    angle_min: typing.Optional[float] = None
    angle_increment: typing.Optional[float] = None
    no_return_range: float = 0.0


@dataclasses.dataclass
class Frame:
    """One camera frame of a visual session: JPEG/PNG bytes or a file path; depth an optional
    16-bit PNG; boxes (x, y, width, height, label) of movable objects, None = the server's
    detector decides."""
    stamp: float
    image: typing.Any
    depth: typing.Any = None
    boxes: typing.Optional[typing.Sequence[tuple]] = None
    want_features: bool = False


# --- tokens ----------------------------------------------------------------------------------

# "robot", "mapper", "admin" (and whatever roles the API has: the names of TokenRole).
ROLES = {name.lower(): number for name, number in token_pb2.TokenRole.items() if number != 0}
_ROLE_NAMES = {number: name for name, number in ROLES.items()}


@dataclasses.dataclass
class Token:
    name: str
    robot_id: str
    role: str  # "robot", "mapper", "admin" (ROLES)
    created_at: float
    expires_at: float    # 0 = never
    revoked_at: float    # 0 = live
    last_used_at: float  # 0 = never used

    @classmethod
    def of(cls, t):
        return cls(t.name, t.robot_id, _ROLE_NAMES.get(t.role, "unspecified"), t.created_at_unix,
                   t.expires_at_unix, t.revoked_at_unix, t.last_used_at_unix)


@dataclasses.dataclass
class CreatedToken:
    token: Token
    secret: str  # "wm_" + 64 hex digits: shown only now

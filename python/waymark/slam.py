"""SLAM sessions: create, list, close, delete, read the map, grid and trajectory, and stream
scans and odometry (laser) or camera frames (visual) into them (waymark.v1.SlamService; the C++
client's client/lib/slam_client.h)."""
import threading

from waymark import _inputs, _streams
from waymark._stubs import slam_pb2, slam_pb2_grpc
from waymark.errors import invalid_argument
from waymark.typed import (Frame, OccupancyGrid, Odometry, Scan, SegmentMap, Session,
                           SlamUpdate, Trajectory)

# Scans in flight on one stream (sent, not yet answered): well under the server's session queue
# (64 messages), with room for the odometry message before each scan (client/lib/slam_client.h).
DEFAULT_SCAN_WINDOW = 16
# Frames in flight on a visual session's stream: each is ~0.1-1 MB.
DEFAULT_FRAME_WINDOW = 4
# Closing a laser session waits for its loop-closing back end (tens of seconds after a fast replay
# of a large log): its deadline is the longer of the client's timeout and this.
CLOSE_SESSION_TIMEOUT = 600.0

_PRESETS = {"measured_best": slam_pb2.VisualSlamConfig.PRESET_MEASURED_BEST,
            "paper": slam_pb2.VisualSlamConfig.PRESET_PAPER}


def _sensor_data(item):
    """(SensorData with its payload, kind) of an Odometry, Scan, Frame or their messages."""
    data = slam_pb2.SensorData()
    if isinstance(item, Odometry):
        data.odometry.stamp = item.stamp
        pose = data.odometry.pose
        pose.x, pose.y, pose.theta = item.x, item.y, item.theta
        return data, "odometry"
    if isinstance(item, Scan):
        data.scan.stamp = item.stamp
        data.scan.ranges.extend(item.ranges)
        if item.angle_min is not None or item.angle_increment is not None:
            if item.angle_min is None or item.angle_increment is None:
                raise invalid_argument("a scan's geometry needs both angle_min and angle_increment")
            g = data.scan.geometry
            g.angle_min, g.angle_increment = item.angle_min, item.angle_increment
            g.beam_count, g.no_return_range = len(item.ranges), item.no_return_range
        return data, "scan"
    if isinstance(item, Frame):
        f = data.frame
        f.stamp = item.stamp
        f.image = _inputs.image_bytes(item.image, "frame image")
        if item.depth is not None:
            f.depth = _inputs.image_bytes(item.depth, "depth image")
        if item.boxes is not None:
            f.boxes_supplied = True
            for box in item.boxes:
                x, y, w, h = box[:4]
                f.boxes.add(x=x, y=y, width=w, height=h, label=box[4] if len(box) > 4 else "")
        f.want_features = item.want_features
        return data, "frame"
    if isinstance(item, slam_pb2.Odometry):
        data.odometry.CopyFrom(item)
        return data, "odometry"
    if isinstance(item, slam_pb2.LaserScan):
        data.scan.CopyFrom(item)
        return data, "scan"
    if isinstance(item, slam_pb2.ImageFrame):
        data.frame.CopyFrom(item)
        return data, "frame"
    raise invalid_argument("a sensor stream takes waymark.Odometry, waymark.Scan or "
                           f"waymark.Frame (or their messages), got {type(item).__name__}")


class _Window:
    """At most `size` scans or frames outstanding; a rejection counts as an answer."""

    def __init__(self, size):
        if size < 1:
            raise invalid_argument(f"window must be at least 1, got {size}")
        self._free = threading.Semaphore(size)
        self._lock = threading.Lock()
        self._outstanding = set()

    def acquire(self, sequence, stopped):
        while not self._free.acquire(timeout=0.2):
            if stopped.is_set():
                return False
        with self._lock:
            self._outstanding.add(sequence)
        return True

    def answered(self, sequence):
        with self._lock:
            if sequence not in self._outstanding:
                return
            self._outstanding.discard(sequence)
        self._free.release()


class SlamMixin:
    """Methods of waymark.Client; `self._unary(method, request, read)` makes the call."""

    def _init_slam(self, channel):
        self.slam_stub = slam_pb2_grpc.SlamServiceStub(channel)

    # --- sessions --------------------------------------------------------------------------

    def create_session(self, robot_id="", name="", laser=None, visual=None, map=None,
                       initial_map_pose=None):
        """Opens a session from a LaserSlamConfig or VisualSlamConfig (a message or a dict of its
        fields); neither is a laser session with the defaults. `map`: the name of a shared map the
        (laser, mapping) session joins; `initial_map_pose` (x, y, theta): where the robot starts
        in that map's frame, when known (it is then tied in at once; else the server finds it from
        its scans). Returns a waymark.Session."""
        request = slam_pb2.CreateSessionRequest(robot_id=robot_id, name=name, map=map or "")
        if initial_map_pose is not None:
            (request.initial_map_pose.x, request.initial_map_pose.y,
             request.initial_map_pose.theta) = (float(v) for v in initial_map_pose)
        if laser is not None and visual is not None:
            raise invalid_argument("a session is laser or visual, not both")
        if laser is not None:
            request.laser.CopyFrom(
                _inputs.params_message(slam_pb2.LaserSlamConfig, laser, "laser config"))
        if visual is not None:
            request.visual.CopyFrom(
                _inputs.params_message(slam_pb2.VisualSlamConfig, visual, "visual config"))
        return Session.of(self._unary(self.slam_stub.CreateSession, request, read=False))

    def create_laser_session(self, robot_id="", name="", *, beam_count, angle_min,
                             angle_increment, no_return_range=0.0, laser_pose=(0.0, 0.0, 0.0),
                             params=None, loop_closure=None, map=None,
                             initial_map_pose=None):
        """A laser SLAM session for a laser of `beam_count` beams from `angle_min` every
        `angle_increment` radians, mounted at laser_pose (x, y, theta) on the robot. `params`: a
        LaserSlamParams or a dict of its fields (e.g. {"max_range": 20})."""
        config = slam_pb2.LaserSlamConfig()
        config.laser.beam_count, config.laser.angle_min = int(beam_count), float(angle_min)
        config.laser.angle_increment = float(angle_increment)
        config.laser.no_return_range = float(no_return_range)
        config.laser_pose.x, config.laser_pose.y, config.laser_pose.theta = laser_pose
        config.params.CopyFrom(
            _inputs.params_message(slam_pb2.LaserSlamParams, params, "laser params"))
        if loop_closure is not None:
            config.params.loop_closure = loop_closure
        return self.create_session(robot_id, name, laser=config, map=map,
                                   initial_map_pose=initial_map_pose)

    def create_visual_session(self, robot_id="", name="", *, fx, fy, cx, cy, width, height,
                              distortion=(), depth_scale=None, preset="measured_best",
                              params=None):
        """A visual odometry session for a pinhole camera (pixels of the frames sent); preset
        "measured_best" (the default) or "paper". `params`: a VisualSlamParams or a dict."""
        if preset not in _PRESETS:
            raise invalid_argument(f"preset {preset!r}: expected one of {sorted(_PRESETS)}")
        config = slam_pb2.VisualSlamConfig(preset=_PRESETS[preset])
        c = config.camera
        c.fx, c.fy, c.cx, c.cy, c.width, c.height = fx, fy, cx, cy, int(width), int(height)
        c.distortion.extend(distortion)
        if depth_scale is not None:
            config.depth_scale = depth_scale
        config.params.CopyFrom(
            _inputs.params_message(slam_pb2.VisualSlamParams, params, "visual params"))
        return self.create_session(robot_id, name, visual=config)

    def list_sessions(self, robot_id=""):
        """Sessions of `robot_id` ("" = every robot the token may see): [waymark.Session]."""
        response = self._unary(self.slam_stub.ListSessions,
                               slam_pb2.ListSessionsRequest(robot_id=robot_id), read=True)
        return [Session.of(s) for s in response.sessions]

    def close_session(self, session_id):
        """Writes a final checkpoint and closes the session (waits for the loop-closing back
        end); returns the closed waymark.Session."""
        timeout = None if self.timeout is None else max(self.timeout, CLOSE_SESSION_TIMEOUT)
        request = slam_pb2.CloseSessionRequest(session_id=session_id)
        return Session.of(self._unary(self.slam_stub.CloseSession, request, read=False,
                                      timeout=timeout))

    def delete_session(self, session_id, force=False):
        """Deletes a session and its stored data (`force` closes an open one first); returns
        the session as it was."""
        timeout = None if self.timeout is None else max(self.timeout, CLOSE_SESSION_TIMEOUT)
        request = slam_pb2.DeleteSessionRequest(session_id=session_id, force=force)
        return Session.of(self._unary(self.slam_stub.DeleteSession, request, read=False,
                                      timeout=timeout).session)

    # --- what a session holds --------------------------------------------------------------

    def get_map(self, session_id):
        """A laser session's segment map: a waymark.SegmentMap."""
        return SegmentMap.of(self._unary(self.slam_stub.GetMap,
                                         slam_pb2.GetMapRequest(session_id=session_id), read=True))

    def get_trajectory(self, session_id):
        return Trajectory.of(self._unary(self.slam_stub.GetTrajectory,
                                         slam_pb2.GetTrajectoryRequest(session_id=session_id),
                                         read=True))

    def get_grid(self, session_id, resolution=None):
        """A laser session's occupancy grid (resolution in m per cell, None = the server's
        0.05): a waymark.OccupancyGrid. FAILED_PRECONDITION for a session with loop closure off."""
        request = slam_pb2.GetOccupancyGridRequest(session_id=session_id)
        if resolution is not None:
            request.resolution = resolution
        return OccupancyGrid.of(self._unary(self.slam_stub.GetOccupancyGrid, request, read=True))

    def import_map(self, robot_id, name, grid):
        """Stores an occupancy grid (a waymark.OccupancyGrid or its message) as a closed laser
        session to localize on; returns the new waymark.Session."""
        message = grid.raw if isinstance(grid, OccupancyGrid) else grid
        request = slam_pb2.ImportMapRequest(robot_id=robot_id, name=name, grid=message)
        return Session.of(self._unary(self.slam_stub.ImportMap, request, read=False))

    # --- maps shared by robots (docs/laser-slam.md, "Maps shared by robots") ----------------
    # These return the API's messages (waymark.v1 Map: name, revision, trajectories with their
    # session, robot and whether each is tied into the map frame).

    def create_map(self, name):
        return self._unary(self.slam_stub.CreateMap, slam_pb2.CreateMapRequest(name=name),
                           read=False)

    def list_maps(self):
        return list(self._unary(self.slam_stub.ListMaps, slam_pb2.ListMapsRequest(),
                                read=True).maps)

    def get_map_info(self, name):
        return self._unary(self.slam_stub.GetMapInfo, slam_pb2.GetMapInfoRequest(name=name),
                           read=True)

    def delete_map(self, name, force=False):
        """Deletes a map (never a session); `force` detaches open sessions instead of refusing.
        Returns the map as it was."""
        request = slam_pb2.DeleteMapRequest(name=name, force=force)
        return self._unary(self.slam_stub.DeleteMap, request, read=False).map

    # --- streams ---------------------------------------------------------------------------

    def stream_laser(self, session_id, readings, window=DEFAULT_SCAN_WINDOW):
        """Streams `readings` (waymark.Odometry and waymark.Scan, in time order: the odometry
        before each scan) into a laser session; yields a waymark.SlamUpdate per processed scan
        and per rejected message, in order.

        At most `window` scans are in flight, so a sender faster than the session never
        overflows the server's bounded queue: `readings` is read only as answers come back.
        Stopping early (break) ends the stream; the session stays open."""
        return self._sensor_stream(session_id, readings, window, ("scan",))

    def stream_frames(self, session_id, frames, window=DEFAULT_FRAME_WINDOW):
        """Streams waymark.Frame items into a visual session; yields a waymark.SlamUpdate per
        frame (pose3d, tracking) or rejection, with at most `window` frames in flight."""
        return self._sensor_stream(session_id, frames, window, ("frame",))

    def _sensor_stream(self, session_id, items, window, windowed_kinds):
        if not session_id:
            raise invalid_argument("session_id is empty")
        flow = _Window(window)

        def requests():
            sequence = 0
            for item in items:
                data, kind = _sensor_data(item)
                sequence += 1
                data.sequence = sequence
                if sequence == 1:
                    data.session_id = session_id
                if kind in windowed_kinds and not flow.acquire(sequence, feed.stopped):
                    return
                yield data

        feed = _streams.RequestFeed(requests())

        def convert(update):
            flow.answered(update.sequence)
            return SlamUpdate.of(update)

        def run():  # the call starts at the caller's first next()
            call = self.slam_stub.StreamSensorData(feed, timeout=self.stream_timeout)
            yield from _streams.answers(call, feed, convert)
        return run()


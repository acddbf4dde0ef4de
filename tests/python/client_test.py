"""The Python client (python/waymark) against the real waymark-server binary (issue 37).

Each class starts its own server on a free port (127.0.0.1:0; the server prints the port it
took) with its own database in a temporary folder: --insecure-dev, or authentication on with an
admin token made on the database file first, as docs/multi-robot.md deploys it; TlsTest adds
certificates made with openssl. Real data from ../shared: crossing photos
(data/vpr/gardenspoint_sfu_triplets_sample: three photos of each place, p0..p9), a CARMEN log
(data/laser/intel) and KITTI frames (data/vslam/kitti_odom06_frames000-050).

Run by run.sh (ctest: python_client_<Class>), which sets PYTHONPATH and the paths below.
"""
import glob
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest

import grpc

import waymark

SOURCE = os.environ["WAYMARK_SOURCE_DIR"]
SHARED = os.environ["WAYMARK_SHARED_DIR"]
SERVER = os.environ["WAYMARK_SERVER_BINARY"]
CLI = os.environ["WAYMARK_CLI_BINARY"]
TRIPLETS = os.path.join(SHARED, "data/vpr/gardenspoint_sfu_triplets_sample")
CORRIDOR = os.path.join(SHARED, "data/vpr/corridor_vprbench")
INTEL = os.path.join(SHARED, "data/laser/intel/intel.clf.bz2")
KITTI = os.path.join(SHARED, "data/vslam/kitti_odom06_frames000-050")
EXAMPLES = os.path.join(SOURCE, "python/examples")

sys.path.insert(0, EXAMPLES)
import replay_carmen  # noqa: E402  (the example's CARMEN reader)


def triplet(place, shot):
    """The photo of place p<place> taken on traversal i<shot>."""
    found = sorted(glob.glob(os.path.join(TRIPLETS, f"p{place}/i{shot}/*.jpg")))
    if not found:
        raise unittest.SkipTest(f"no photo p{place}/i{shot} under {TRIPLETS}")
    return found[0]


class Server:
    """waymark-server on 127.0.0.1:0 with a database of its own; stdout and stderr in a log."""

    def __init__(self, folder, auth=False, args=()):
        self.db = os.path.join(folder, "waymark.db")
        self.log_path = os.path.join(folder, f"server-{time.monotonic_ns()}.log")
        self.auth, self.args = auth, list(args)
        self.process = None
        self.address = None

    def create_token(self, name, role):
        """A token made on the database file, as the first admin's is (`waymark-server token`)."""
        out = subprocess.run([SERVER, "--db", self.db, "token", "create", name, "--role", role],
                             check=True, capture_output=True, text=True)
        return out.stdout.strip()

    def start(self):
        argv = [SERVER, "--listen", "127.0.0.1:0", "--db", self.db] + self.args
        if not self.auth:
            argv.append("--insecure-dev")
        with open(self.log_path, "wb") as log:
            self.process = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 60
        marker = "listening on "
        while time.monotonic() < deadline:
            with open(self.log_path, errors="replace") as f:
                text = f.read()
            at = text.find(marker)
            if at >= 0 and text.find("\n", at) >= 0:
                self.address = text[at + len(marker):text.find("\n", at)].strip()
                return self
            if self.process.poll() is not None:
                raise RuntimeError(f"server exited before listening:\n{text}")
            time.sleep(0.05)
        raise RuntimeError(f"server did not report listening in 60 s:\n{self.log()}")

    def log(self):
        with open(self.log_path, errors="replace") as f:
            return f.read()

    def stop(self):
        if self.process and self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(60)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


class ServerCase(unittest.TestCase):
    """A server per class, on --insecure-dev unless AUTH."""
    AUTH = False
    ARGS = ()

    @classmethod
    def setUpClass(cls):
        cls.folder = tempfile.mkdtemp(prefix="waymark-python-")
        cls.server = Server(cls.folder, auth=cls.AUTH, args=cls.ARGS)
        cls.prepare()
        cls.server.start()

    @classmethod
    def prepare(cls):
        """Before the server starts (e.g. tokens on the database file)."""

    @classmethod
    def tearDownClass(cls):
        cls.server.stop()
        shutil.rmtree(cls.folder, ignore_errors=True)

    def connect(self, **kwargs):
        """A client of this class's server, closed when the test ends (an open channel holds
        the server's shutdown for seconds)."""
        client = waymark.connect(kwargs.pop("address", self.server.address), **kwargs)
        self.addCleanup(client.close)
        return client

    def assertRaisesCode(self, code, call, *args, **kwargs):
        with self.assertRaises(waymark.Error) as caught:
            result = call(*args, **kwargs)
            if hasattr(result, "__next__"):  # a stream: the error comes while reading it
                list(result)
        self.assertEqual(caught.exception.code, code, caught.exception.message)
        return caught.exception


class ClientTest(ServerCase):
    """Connect, databases, enrollment and recognition of real photos, errors."""

    def setUp(self):
        self.client = self.connect()

    def test_health_and_databases(self):
        self.client.wait_ready(10)
        self.assertEqual(self.client.health(), "SERVING")
        self.assertEqual(self.client.health("waymark.v1.SlamService"), "SERVING")
        self.assertNotIn("health-db", [d.name for d in self.client.list_databases()])
        created = self.client.create_database("health-db", {"hue_bins": 24})
        self.assertEqual(created.name, "health-db")
        self.assertEqual(created.raw.params.hue_bins, 24)
        listed = {d.name: d for d in self.client.list_databases()}
        self.assertIn("health-db", listed)
        self.assertEqual(listed["health-db"].views, 0)
        self.assertRaisesCode(grpc.StatusCode.ALREADY_EXISTS, self.client.create_database,
                              "health-db")

    def test_enroll_and_recognize_real_photos(self):
        db = "gardens"
        self.client.create_database(db, {"keep_aspect": True, "root_sift": True,
                                         "recognition": {"mode": "retrieval"}})
        # The first traversal one view at a time (file paths), the second over one stream
        # (bytes), facing another way.
        first_views = []
        for place in range(10):
            result = self.client.enroll(db, f"p{place}", 0, triplet(place, 0))
            first_views.append(result.view_id)
            self.assertEqual(result.outcome, "stored")
            self.assertEqual(result.crossing, f"p{place}")
            self.assertGreater(result.keypoints, 0)
        views = []
        for place in range(10):
            with open(triplet(place, 1), "rb") as f:
                views.append((f"p{place}", 90, f.read()))
        streamed = list(self.client.enroll_many(db, views))
        self.assertEqual([r.outcome for r in streamed], ["stored"] * 10)
        self.assertEqual([r.heading_deg for r in streamed], [90.0] * 10)
        again = self.client.enroll(db, "p0", 0, triplet(0, 0))
        self.assertEqual(again.outcome, "duplicate")
        self.assertEqual(again.view_id, first_views[0])
        self.assertEqual({c.name: c.views for c in self.client.list_crossings(db)},
                         {f"p{place}": 2 for place in range(10)})

        # The third traversal: places 3 and 9 are recognized on their geometry (measured: log10
        # NFA -10.1 and -39.9), facing the second traversal's way.
        for place in (3, 9):
            answer = self.client.recognize(db, triplet(place, 2))
            self.assertTrue(answer.accepted, answer.reason)
            self.assertEqual(answer.crossing, f"p{place}")
            self.assertEqual(answer.heading_deg, 90.0)
            self.assertEqual(answer.accepted_by, "nfa")
            self.assertEqual(answer.mode, "retrieval")
            self.assertLess(answer.log10_nfa, 0)
            self.assertTrue(answer.candidates)
        # A corridor far away is no crossing of this database: refused, saying why.
        corridor = sorted(glob.glob(os.path.join(CORRIDOR, "query/*.jpg")))[0]
        refused = self.client.recognize(db, corridor)
        self.assertFalse(refused.accepted)
        self.assertEqual(refused.accepted_by, "refused")
        self.assertIsNone(refused.heading_deg)
        self.assertTrue(refused.reason)
        # The paper's mode, asked per request, answers in that mode.
        paper = self.client.recognize(db, triplet(3, 2), params={"mode": "paper"})
        self.assertEqual(paper.mode, "paper")
        # The frame loop over one stream: one answer per image, in order (each frame on its
        # own: no evidence over frames).
        frames = list(self.client.recognize_stream(db, [triplet(3, 2), triplet(9, 2)],
                                                   params={"evidence_threshold": 0}))
        self.assertEqual([f.crossing for f in frames], ["p3", "p9"])
        self.assertEqual([f.raw.frame_index for f in frames], [0, 1])

    def test_errors(self):
        error = self.assertRaisesCode(grpc.StatusCode.NOT_FOUND, self.client.recognize,
                                      "no-such-db", triplet(0, 0))
        self.assertIn("no-such-db", error.message)
        self.assertEqual(error.code_name, "NOT_FOUND")
        self.assertTrue(str(error).startswith("NOT_FOUND: "))
        # Refused before sending: a file that is not there, an unknown parameter.
        missing = os.path.join(self.folder, "missing.jpg")
        error = self.assertRaisesCode(grpc.StatusCode.NOT_FOUND, self.client.recognize,
                                      "no-such-db", missing)
        self.assertIn(missing, error.message)
        self.assertRaisesCode(grpc.StatusCode.INVALID_ARGUMENT, self.client.create_database,
                              "x", {"no_such_field": 1})
        # The server's own checks: a name it refuses, bytes that are no image.
        self.assertRaisesCode(grpc.StatusCode.INVALID_ARGUMENT, self.client.create_database,
                              "bad name!")
        self.client.create_database("errors-db")
        self.assertRaisesCode(grpc.StatusCode.INVALID_ARGUMENT, self.client.enroll,
                              "errors-db", "c", 0, b"not an image")
        # An image file the stream cannot read ends the stream with the reader's own error.
        self.assertRaisesCode(grpc.StatusCode.NOT_FOUND, self.client.enroll_many, "errors-db",
                              [("c", 0, missing)])

    def test_unreachable_server_is_unavailable(self):
        client = self.connect(address="127.0.0.1:1", timeout=5,
                              retry=waymark.RetryOptions(max_attempts=2, initial_backoff=0.05))
        self.assertRaisesCode(grpc.StatusCode.UNAVAILABLE, client.list_databases)
        self.assertRaisesCode(grpc.StatusCode.UNAVAILABLE, client.wait_ready, 0.5)


class SlamTest(ServerCase):
    """A laser session fed with real scans of the Intel log, and a visual session with KITTI
    frames."""

    def setUp(self):
        self.client = self.connect()
        if not os.path.exists(INTEL):
            self.skipTest(f"{INTEL} is absent")
        lines = replay_carmen.in_stamp_order(replay_carmen.flaser_lines(INTEL))
        self.lines = list(_take(lines, 80))

    def _create(self, name):
        stamp, ranges, odom, laser = self.lines[0]
        return self.client.create_laser_session(
            "py-robot", name, beam_count=len(ranges), angle_min=-1.5707963267948966,
            angle_increment=replay_carmen.beam_step(len(ranges)),
            laser_pose=replay_carmen.laser_mount(odom, laser))

    def _readings(self, lines):
        for stamp, ranges, odom, _ in lines:
            yield waymark.Odometry(stamp, *odom)
            yield waymark.Scan(stamp, ranges)

    def test_laser_session_lifecycle(self):
        session = self._create("python lifecycle")
        self.assertEqual(session.kind, "laser")
        self.assertEqual(session.state, "open")
        updates = list(self.client.stream_laser(session.session_id, self._readings(self.lines)))
        self.assertEqual([u.rejection for u in updates], [None] * len(self.lines))
        self.assertEqual([u.sequence for u in updates], list(range(2, 2 * len(self.lines) + 1, 2)))
        self.assertEqual(updates[-1].scans_processed, len(self.lines))
        self.assertEqual(updates[0].raw.stream_start.scans_processed, 0)
        self.assertIsNotNone(updates[-1].pose)
        self.assertEqual(len(updates[-1].covariance), 9)

        listed = {s.session_id: s for s in self.client.list_sessions("py-robot")}
        self.assertEqual(listed[session.session_id].scans_processed, len(self.lines))
        segment_map = self.client.get_map(session.session_id)
        self.assertGreater(segment_map.segments, 0)
        self.assertLessEqual(segment_map.pruned_nodes, segment_map.graph_nodes)
        grid = self.client.get_grid(session.session_id, resolution=0.1)
        self.assertEqual(len(grid.cells), grid.width * grid.height)
        unknown, free, occupied = grid.counts()
        self.assertGreater(free, 0)
        self.assertGreater(occupied, 0)
        trajectory = self.client.get_trajectory(session.session_id)
        self.assertTrue(trajectory.poses)
        self.assertIsNotNone(trajectory.poses[-1].pose)

        closed = self.client.close_session(session.session_id)
        self.assertEqual(closed.state, "closed")
        self.assertEqual(closed.scans_processed, len(self.lines))
        deleted = self.client.delete_session(session.session_id)
        self.assertEqual(deleted.session_id, session.session_id)
        self.assertNotIn(session.session_id, [s.session_id for s in self.client.list_sessions()])
        self.assertRaisesCode(grpc.StatusCode.NOT_FOUND, self.client.get_map, session.session_id)

    def test_a_session_joins_a_shared_map(self):
        self.client.create_map("py-floor")
        self.assertIn("py-floor", [m.name for m in self.client.list_maps()])
        self.assertRaisesCode(grpc.StatusCode.ALREADY_EXISTS, self.client.create_map, "py-floor")
        stamp, ranges, odom, laser = self.lines[0]
        session = self.client.create_laser_session(
            "py-robot", "python in a map", beam_count=len(ranges), angle_min=-1.5707963267948966,
            angle_increment=replay_carmen.beam_step(len(ranges)),
            laser_pose=replay_carmen.laser_mount(odom, laser), map="py-floor")
        info = self.client.get_map_info("py-floor")
        self.assertEqual([t.session_id for t in info.trajectories], [session.session_id])
        self.assertTrue(info.trajectories[0].tied_in)  # the first robot defines the map frame
        # A second robot with a known start is tied in there at once.
        second = self.client.create_laser_session(
            "py-robot-2", "python in a map, known start", beam_count=len(ranges),
            angle_min=-1.5707963267948966, angle_increment=replay_carmen.beam_step(len(ranges)),
            laser_pose=replay_carmen.laser_mount(odom, laser), map="py-floor",
            initial_map_pose=(1.5, -2.0, 0.25))
        info = self.client.get_map_info("py-floor")
        self.assertTrue(info.trajectories[1].tied_in)
        self.assertEqual((info.trajectories[1].origin.x, info.trajectories[1].origin.y,
                          info.trajectories[1].origin.theta), (1.5, -2.0, 0.25))
        self.assertRaisesCode(grpc.StatusCode.FAILED_PRECONDITION, self.client.delete_map,
                              "py-floor")  # an open session is in it
        deleted = self.client.delete_map("py-floor", force=True)
        self.assertEqual(deleted.name, "py-floor")
        self.assertRaisesCode(grpc.StatusCode.NOT_FOUND, self.client.get_map_info, "py-floor")
        self.client.delete_session(session.session_id, force=True)
        self.client.delete_session(second.session_id, force=True)

    def test_rejections_are_answers_and_the_stream_goes_on(self):
        session = self._create("python rejections")
        lines = self.lines[:6]
        stamp, ranges, odom, _ = lines[2]
        readings = list(self._readings(lines[:3]))
        readings.append(waymark.Scan(stamp - 1.0, ranges))  # earlier than the scan before
        readings.extend(self._readings(lines[3:]))
        updates = list(self.client.stream_laser(session.session_id, readings))
        rejected = [u for u in updates if u.rejection]
        self.assertEqual(len(rejected), 1)
        self.assertEqual(rejected[0].sequence, 7)
        self.assertEqual(rejected[0].rejection.code, grpc.StatusCode.INVALID_ARGUMENT)
        self.assertIn("stamp", rejected[0].rejection.message)
        self.assertEqual(updates[-1].scans_processed, 6)
        self.client.delete_session(session.session_id, force=True)

    def test_window_bounds_scans_in_flight(self):
        session = self._create("python window")
        window, answered, in_flight = 2, [0], []

        def readings():
            sent = 0
            for reading in self._readings(self.lines[:30]):
                if isinstance(reading, waymark.Scan):
                    sent += 1
                    # The window is freed as an answer is handed over, before the loop below
                    # counts it: one more than the window is the most this can see.
                    in_flight.append(sent - answered[0])
                yield reading

        for _ in self.client.stream_laser(session.session_id, readings(), window=window):
            answered[0] += 1
        self.assertEqual(answered[0], 30)
        self.assertLessEqual(max(in_flight), window + 1)
        self.client.delete_session(session.session_id, force=True)

    def test_stopping_early_leaves_the_session_open(self):
        session = self._create("python early stop")
        stream = self.client.stream_laser(session.session_id, self._readings(self.lines))
        first = [next(stream) for _ in range(5)]
        stream.close()
        self.assertEqual(first[-1].scans_processed, 5)
        listed = {s.session_id: s for s in self.client.list_sessions("py-robot")}
        self.assertEqual(listed[session.session_id].state, "open")
        # A new stream takes the session up where it was.
        updates = list(self.client.stream_laser(session.session_id,
                                                self._readings(self.lines[40:45])))
        self.assertEqual([u.rejection for u in updates], [None] * 5)
        self.assertGreater(updates[-1].scans_processed, 5)
        self.client.delete_session(session.session_id, force=True)

    def test_visual_session_tracks_kitti_frames(self):
        images = sorted(glob.glob(os.path.join(KITTI, "image_0/*.png")))[:6]
        if len(images) < 6:
            self.skipTest(f"no KITTI frames under {KITTI}")
        with open(os.path.join(KITTI, "calib.txt")) as f:
            p0 = [float(v) for v in f.readline().split()[-12:]]
        session = self.client.create_visual_session(
            "py-robot", "python kitti", fx=p0[0], fy=p0[5], cx=p0[2], cy=p0[6], width=1226,
            height=370)
        self.assertEqual(session.kind, "visual")
        frames = [waymark.Frame(0.1 * i, path) for i, path in enumerate(images)]
        updates = list(self.client.stream_frames(session.session_id, frames))
        self.assertEqual([u.rejection for u in updates], [None] * 6)
        self.assertTrue(all(u.pose3d is not None for u in updates))
        self.assertIn("TRACKING", [u.tracking for u in updates])
        self.assertEqual(len(self.client.get_trajectory(session.session_id).poses), 6)
        self.assertRaisesCode(grpc.StatusCode.FAILED_PRECONDITION, self.client.get_map,
                              session.session_id)
        self.client.delete_session(session.session_id, force=True)


class AuthTest(ServerCase):
    """Authentication on: the bearer token, tokens over the API, roles, revocation."""
    AUTH = True

    @classmethod
    def prepare(cls):
        cls.admin_secret = cls.server.create_token("admin", "admin")

    def test_no_token_is_unauthenticated_and_health_needs_none(self):
        client = self.connect()
        self.assertEqual(client.health(), "SERVING")
        self.assertRaisesCode(grpc.StatusCode.UNAUTHENTICATED, client.list_databases)
        wrong = self.connect(token="wm_" + "0" * 64)
        self.assertRaisesCode(grpc.StatusCode.UNAUTHENTICATED, wrong.list_databases)

    def test_tokens_roles_and_revocation(self):
        admin = self.connect(token=self.admin_secret)
        admin.create_database("auth-db")
        created = admin.create_token("robot-7", role="robot", expires_in=3600)
        self.assertTrue(created.secret.startswith("wm_"))
        self.assertEqual(created.token.role, "robot")
        self.assertEqual(created.token.robot_id, "robot-7")
        self.assertGreater(created.token.expires_at, created.token.created_at)
        self.assertIn("robot-7", [t.name for t in admin.list_tokens()])
        self.assertRaisesCode(grpc.StatusCode.INVALID_ARGUMENT, admin.create_token, "x",
                              role="pilot")

        robot = self.connect(token=created.secret)
        self.assertIn("auth-db", [d.name for d in robot.list_databases()])
        error = self.assertRaisesCode(grpc.StatusCode.PERMISSION_DENIED, robot.create_database,
                                      "robot-db")
        self.assertIn("robot-7", error.message)
        self.assertRaisesCode(grpc.StatusCode.PERMISSION_DENIED, robot.list_tokens)
        # The raw stubs carry the token too.
        from waymark.v1 import crossing_pb2
        self.assertTrue(robot.crossing_stub.ListDatabases(crossing_pb2.ListDatabasesRequest(),
                                                          timeout=10).databases)
        # A robot's session is its own.
        session = robot.create_laser_session(beam_count=180, angle_min=-1.57,
                                             angle_increment=0.01745)
        self.assertEqual(session.robot_id, "robot-7")

        revoked = admin.revoke_token("robot-7")
        self.assertGreater(revoked.revoked_at, 0)
        self.assertRaisesCode(grpc.StatusCode.UNAUTHENTICATED, robot.list_databases)


class TlsTest(ServerCase):
    """TLS with a CA of the test's own (openssl), authentication on."""
    AUTH = True

    @classmethod
    def setUpClass(cls):
        if shutil.which("openssl") is None:
            raise unittest.SkipTest("no openssl to make test certificates")
        super().setUpClass()

    @classmethod
    def prepare(cls):
        d = cls.folder
        with open(os.path.join(d, "san.ext"), "w") as f:
            f.write("subjectAltName=DNS:localhost,IP:127.0.0.1\n")

        def openssl(*args):
            subprocess.run(["openssl", *args], cwd=d, check=True, capture_output=True)
        ec = ["-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes"]
        for ca in ("ca", "other-ca"):
            openssl("req", "-x509", *ec, "-days", "2", "-keyout", f"{ca}.key", "-out",
                    f"{ca}.pem", "-subj", f"/CN={ca}")
        openssl("req", *ec, "-keyout", "server.key", "-out", "server.csr", "-subj", "/CN=localhost")
        openssl("x509", "-req", "-in", "server.csr", "-CA", "ca.pem", "-CAkey", "ca.key",
                "-CAcreateserial", "-days", "2", "-out", "server.pem", "-extfile", "san.ext")
        cls.server.args += ["--tls-cert", os.path.join(d, "server.pem"),
                            "--tls-key", os.path.join(d, "server.key")]
        cls.token = cls.server.create_token("tls-robot", "robot")

    def test_trusted_ca_connects_other_ca_and_plaintext_do_not(self):
        ca = os.path.join(self.folder, "ca.pem")
        client = self.connect(token=self.token, ca_file=ca)
        self.assertEqual(client.list_databases(), [])
        # By the name the certificate carries, when the address is another.
        named = self.connect(token=self.token, ca_file=ca, tls_server_name="localhost")
        self.assertEqual(named.list_databases(), [])
        fast = waymark.RetryOptions(max_attempts=1)
        other = self.connect(token=self.token, timeout=10, retry=fast,
                             ca_file=os.path.join(self.folder, "other-ca.pem"))
        self.assertRaisesCode(grpc.StatusCode.UNAVAILABLE, other.list_databases)
        plain = self.connect(token=self.token, timeout=10, retry=fast)
        self.assertRaisesCode(grpc.StatusCode.UNAVAILABLE, plain.list_databases)
        error = self.assertRaisesCode(grpc.StatusCode.INVALID_ARGUMENT, waymark.connect,
                                      self.server.address,
                                      ca_file=os.path.join(self.folder, "san.ext"))
        self.assertIn("not PEM", error.message)


class ExamplesTest(ServerCase):
    """The two examples of python/examples, run as a user runs them."""

    def run_example(self, *args):
        env = dict(os.environ, WAYMARK_SERVER=self.server.address)
        return subprocess.run([sys.executable, *args], env=env, capture_output=True, text=True,
                              timeout=300)

    def test_recognize_image(self):
        client = self.connect()
        client.create_database("example", {"keep_aspect": True, "root_sift": True,
                                           "recognition": {"mode": "retrieval"}})
        list(client.enroll_many("example", [(f"p{p}", 45 * i, triplet(p, i))
                                            for p in range(10) for i in (0, 1)]))
        out = self.run_example(os.path.join(EXAMPLES, "recognize_image.py"), "example",
                               triplet(3, 2))
        self.assertEqual(out.returncode, 0, out.stderr)
        self.assertIn("crossing p3, heading 45 deg (accepted by nfa", out.stdout)
        out = self.run_example(os.path.join(EXAMPLES, "recognize_image.py"), "no-such-db",
                               triplet(3, 2))
        self.assertNotEqual(out.returncode, 0)
        self.assertIn("error: NOT_FOUND", out.stderr)

    def test_replay_carmen(self):
        if not os.path.exists(INTEL):
            self.skipTest(f"{INTEL} is absent")
        out = self.run_example(os.path.join(EXAMPLES, "replay_carmen.py"), "--scans", "50", INTEL)
        self.assertEqual(out.returncode, 0, out.stderr)
        self.assertIn("50 scans answered, 0 rejected, 50 processed", out.stdout)
        self.assertRegex(out.stdout, r"final pose x=-?\d+\.\d{3} m y=-?\d+\.\d{3} m "
                                     r"theta=-?\d+\.\d{3} rad")
        # The example deletes its session.
        self.assertEqual(self.connect().list_sessions(), [])

    def test_replay_example_ends_where_the_command_line_replay_does(self):
        if not os.path.exists(INTEL):
            self.skipTest(f"{INTEL} is absent")
        out = self.run_example(os.path.join(EXAMPLES, "replay_carmen.py"), "--scans", "60", INTEL)
        self.assertEqual(out.returncode, 0, out.stderr)
        match = re.search(r"final pose x=(\S+) m y=(\S+) m theta=(\S+) rad", out.stdout)
        self.assertIsNotNone(match, out.stdout)
        x, y, theta = (float(v) for v in match.groups())
        folder = os.path.join(self.folder, "cli-replay")
        cli = subprocess.run([CLI, "--server", self.server.address, "slam", "replay", INTEL,
                              "--max-scans", "60", "--out", folder],
                             capture_output=True, text=True, timeout=300)
        self.assertEqual(cli.returncode, 0, cli.stdout + cli.stderr)
        with open(os.path.join(folder, "trajectory.txt")) as f:
            last = [line for line in f if not line.startswith("#")][-1].split()
        qz, qw = float(last[6]), float(last[7])
        # The example prints 3 decimals; the two replays send the same scans and odometry.
        self.assertAlmostEqual(x, float(last[1]), delta=0.002)
        self.assertAlmostEqual(y, float(last[2]), delta=0.002)
        self.assertAlmostEqual(theta, 2 * math.atan2(qz, qw), delta=0.002)


def _take(iterable, n):
    for i, item in enumerate(iterable):
        if i >= n:
            return
        yield item


if __name__ == "__main__":
    unittest.main()

"""Crossing recognition: databases, crossings, enrollment, recognition
(waymark.v1.CrossingService; the C++ client's client/lib/crossing_client.h)."""
import math

from waymark import _inputs, _streams
from waymark._stubs import common_pb2, crossing_pb2, crossing_pb2_grpc
from waymark.errors import invalid_argument
from waymark.typed import Crossing, Database, EnrollResult, Recognition


class CrossingMixin:
    """Methods of waymark.Client; `self._unary(method, request, read)` makes the call."""

    def _init_crossing(self, channel):
        self.crossing_stub = crossing_pb2_grpc.CrossingServiceStub(channel)

    # --- databases -------------------------------------------------------------------------

    def list_databases(self):
        """Every crossing database: [waymark.Database]."""
        response = self._unary(self.crossing_stub.ListDatabases,
                               crossing_pb2.ListDatabasesRequest(), read=True)
        return [Database.of(d) for d in response.databases]

    def create_database(self, name, params=None):
        """Creates a database. `params`: a DatabaseParams or a dict of its fields, e.g.
        {"keep_aspect": True, "recognition": {"mode": "retrieval"}}."""
        params = _inputs.params_message(crossing_pb2.DatabaseParams, params, "database params")
        request = crossing_pb2.CreateDatabaseRequest(name=name, params=params)
        return Database.of(self._unary(self.crossing_stub.CreateDatabase, request, read=False))

    def delete_database(self, name):
        self._unary(self.crossing_stub.DeleteDatabase,
                    crossing_pb2.DeleteDatabaseRequest(name=name), read=False)

    def database_stats(self, name):
        """The database's DatabaseStats message (clusters, keypoints, crossings)."""
        return self._unary(self.crossing_stub.GetDatabaseStats,
                           crossing_pb2.GetDatabaseStatsRequest(name=name), read=True)

    # --- crossings -------------------------------------------------------------------------

    def add_crossing(self, database, name, label=""):
        request = crossing_pb2.AddCrossingRequest(database=database, name=name, label=label)
        return Crossing.of(self._unary(self.crossing_stub.AddCrossing, request, read=False))

    def list_crossings(self, database):
        response = self._unary(self.crossing_stub.ListCrossings,
                               crossing_pb2.ListCrossingsRequest(database=database), read=True)
        return [Crossing.of(c) for c in response.crossings]

    def delete_crossing(self, database, name):
        """Deletes a crossing and its views; returns how many views went with it."""
        request = crossing_pb2.DeleteCrossingRequest(database=database, name=name)
        return self._unary(self.crossing_stub.DeleteCrossing, request, read=False).views_deleted

    def rebuild_clusters(self, database, cluster_threshold=None):
        request = crossing_pb2.RebuildClustersRequest(database=database)
        if cluster_threshold is not None:
            request.cluster_threshold = cluster_threshold
        return self._unary(self.crossing_stub.RebuildClusters, request, read=False)

    # --- enrollment ------------------------------------------------------------------------

    @staticmethod
    def _enroll_request(database, crossing, heading, image, create_crossing=True, position="",
                        replace=False, store_image=False, skip_invalid=False):
        request = crossing_pb2.EnrollViewRequest(
            database=database, crossing=crossing,
            image=common_pb2.Image(data=_inputs.image_bytes(image)),
            create_crossing=create_crossing, position=position, replace=replace,
            store_image=store_image, skip_invalid=skip_invalid)
        if heading is None:
            request.heading_unknown = True
        else:
            heading = float(heading)
            if not math.isfinite(heading):
                raise invalid_argument(f"heading {heading} is not a finite number of degrees")
            request.heading_deg = heading % 360.0
        return request

    def enroll(self, database, crossing, heading, image, create_crossing=True, position="",
               replace=False, store_image=False):
        """Enrolls one view of `crossing` taken facing `heading` degrees (clockwise; None: an
        unknown heading). `image`: JPEG/PNG bytes or a file path. Returns a waymark.EnrollResult
        (outcome "stored", or "duplicate" for an image the database already holds)."""
        request = self._enroll_request(database, crossing, heading, image, create_crossing,
                                       position, replace, store_image)
        return EnrollResult.of(self._unary(self.crossing_stub.EnrollView, request, read=False))

    def enroll_many(self, database, views, create_crossing=True, skip_invalid=True):
        """Enrolls (crossing, heading, image) or (crossing, heading, image, position) tuples over
        one StreamEnroll stream; yields a waymark.EnrollResult per view as soon as it is stored,
        in order. With skip_invalid a bad image is answered outcome "invalid" and the stream goes
        on; any other error ends it with a waymark.Error (the views answered before stay)."""
        def requests():
            for view in views:
                crossing, heading, image = view[0], view[1], view[2]
                position = view[3] if len(view) > 3 else ""
                yield self._enroll_request(database, crossing, heading, image, create_crossing,
                                           position, skip_invalid=skip_invalid)
        feed = _streams.RequestFeed(requests())
        call = self.crossing_stub.StreamEnroll(feed, timeout=self.stream_timeout)
        yield from _streams.answers(call, feed, EnrollResult.of)

    # --- recognition -----------------------------------------------------------------------

    def recognize(self, database, image, params=None, stamp=0.0):
        """Which crossing `image` (bytes or a path) shows, and which way the camera faced: a
        waymark.Recognition. `params`: a RecognitionParams or a dict of its fields, e.g.
        {"mode": "verified"}; unset fields take the database's."""
        request = crossing_pb2.RecognizeRequest(
            database=database, image=common_pb2.Image(data=_inputs.image_bytes(image), stamp=stamp),
            params=_inputs.params_message(crossing_pb2.RecognitionParams, params,
                                          "recognition params"))
        return Recognition.of(self._unary(self.crossing_stub.RecognizeCrossing, request, read=True))

    def recognize_stream(self, database, images, params=None):
        """The paper's frame loop over one StreamRecognize stream: yields a waymark.Recognition
        per image of `images` (bytes or paths), in order. A frame the server cannot use is
        answered with raw.error_code set and the stream goes on."""
        params = _inputs.params_message(crossing_pb2.RecognitionParams, params,
                                        "recognition params")

        def requests():
            for i, image in enumerate(images):
                yield crossing_pb2.RecognizeRequest(
                    database=database, params=params,
                    image=common_pb2.Image(data=_inputs.image_bytes(image, f"image {i}")))
        feed = _streams.RequestFeed(requests())
        call = self.crossing_stub.StreamRecognize(feed, timeout=self.stream_timeout)
        yield from _streams.answers(call, feed, Recognition.of)

"""waymark.connect() and the Client: one channel, typed helpers per service, tokens and health."""
import grpc

from waymark import channel as _channel
from waymark._stubs import health_pb2, token_pb2, token_pb2_grpc
from waymark.crossing import CrossingMixin
from waymark.errors import Error, from_rpc_error, invalid_argument
from waymark.retry import RetryOptions, call_unary
from waymark.slam import SlamMixin
from waymark.typed import ROLES, CreatedToken, Token

_HEALTH_CHECK = "/grpc.health.v1.Health/Check"


class Client(CrossingMixin, SlamMixin):
    """Typed, blocking access to a Waymark server. Thread-safe (gRPC channels and stubs are);
    each stream belongs to the thread that iterates it.

    `timeout` (seconds, None = none) bounds every unary call, retries included; reads
    (list_*, get_*, recognize, database_stats) are retried on UNAVAILABLE per `retry`, writes are
    sent once. `stream_timeout` bounds a whole stream (None: streams last as long as the robot
    drives). Every error is a waymark.Error with the server's status code and message.

    The generated stubs are public (crossing_stub, slam_stub, token_stub) for the RPCs' rarer
    fields; calls made on them carry the token too.
    """

    def __init__(self, channel, timeout=30.0, stream_timeout=None, retry=None):
        self.channel = channel
        self.timeout = timeout
        self.stream_timeout = stream_timeout
        self.retry = retry or RetryOptions()
        self._init_crossing(channel)
        self._init_slam(channel)
        self.token_stub = token_pb2_grpc.TokenServiceStub(channel)
        self._health = channel.unary_unary(
            _HEALTH_CHECK, request_serializer=health_pb2.HealthCheckRequest.SerializeToString,
            response_deserializer=health_pb2.HealthCheckResponse.FromString)

    def _unary(self, method, request, read, timeout=None):
        return call_unary(method, request, self.timeout if timeout is None else timeout,
                          self.retry, read)

    def close(self):
        self.channel.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # --- health ----------------------------------------------------------------------------

    def health(self, service="", timeout=5.0):
        """The standard gRPC health check: "SERVING", "NOT_SERVING" or "UNKNOWN" for `service`
        ("" = the server as a whole, or e.g. "waymark.v1.SlamService"). Needs no token;
        waymark.Error UNAVAILABLE when the server cannot be reached within `timeout`."""
        try:
            response = self._health(health_pb2.HealthCheckRequest(service=service), timeout=timeout)
        except grpc.RpcError as e:
            raise from_rpc_error(e) from None
        return health_pb2.HealthCheckResponse.ServingStatus.Name(response.status)

    def wait_ready(self, timeout=10.0):
        """Waits up to `timeout` seconds for the channel to connect; waymark.Error UNAVAILABLE
        if it does not."""
        try:
            grpc.channel_ready_future(self.channel).result(timeout=timeout)
        except grpc.FutureTimeoutError:
            raise Error(grpc.StatusCode.UNAVAILABLE, f"no connection within {timeout} s") from None

    # --- tokens (admin only) ---------------------------------------------------------------

    def create_token(self, name, role="robot", robot_id="", expires_in=None):
        """A new token with its secret (shown only now): waymark.CreatedToken. role: "robot",
        "mapper", "admin" (docs/multi-robot.md); robot_id "" = the name; expires_in seconds,
        None = never."""
        if role not in ROLES:
            raise invalid_argument(f"role {role!r}: expected one of {', '.join(ROLES)}")
        if expires_in is not None and not expires_in > 0:
            raise invalid_argument(f"expires_in must be positive seconds, got {expires_in}")
        request = token_pb2.CreateTokenRequest(name=name, robot_id=robot_id, role=ROLES[role],
                                               expires_in_seconds=expires_in or 0.0)
        created = self._unary(self.token_stub.CreateToken, request, read=False)
        return CreatedToken(Token.of(created.token), created.secret)

    def list_tokens(self):
        response = self._unary(self.token_stub.ListTokens, token_pb2.ListTokensRequest(), read=True)
        return [Token.of(t) for t in response.tokens]

    def revoke_token(self, name):
        """Revokes a token at once; returns it as it now stands."""
        return Token.of(self._unary(self.token_stub.RevokeToken,
                                    token_pb2.RevokeTokenRequest(name=name), read=False))


def connect(address="127.0.0.1:50051", token=None, tls=False, ca_file=None, cert_file=None,
            key_file=None, tls_server_name=None, timeout=30.0, stream_timeout=None, retry=None):
    """A Client of the server at `address` ("host[:port]", port 50051 if omitted; "unix:PATH";
    several servers sharing a database as "a:50051,b:50051").

    token: sent as "authorization: Bearer <token>" on every call (a server with authentication
    on needs one: `waymark token create`). TLS: tls=True trusts the system's CAs, ca_file a PEM
    CA; cert_file/key_file a client certificate (mutual TLS); tls_server_name the name the
    server's certificate carries when not the address's host. As the command line's --token,
    --tls, --tls-ca, --tls-cert, --tls-key and --tls-server-name (docs/multi-robot.md).

    Connects lazily: a server that is down shows as waymark.Error UNAVAILABLE from the first call.
    """
    channel = _channel.make_channel(address, token=token, tls=tls, ca_file=ca_file,
                                    cert_file=cert_file, key_file=key_file,
                                    tls_server_name=tls_server_name)
    return Client(channel, timeout=timeout, stream_timeout=stream_timeout, retry=retry)

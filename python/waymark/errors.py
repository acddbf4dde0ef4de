"""waymark.Error: what every call raises when the server (or the input) says no.

A gRPC error keeps the server's status code and message, exactly as the C++ client's
absl::Status does (client/lib/status_util.h); input the client refuses before sending (an image
file it cannot read, a bad address) gets the code the server would have used.
"""
import grpc


class Error(Exception):
    """A failed call: `code` is a grpc.StatusCode, `message` the server's text.

    `metadata` holds the call's trailing metadata (e.g. waymark-session-owner, which names the
    server that serves a session on a fleet of servers: docs/scale-out.md).
    """

    def __init__(self, code, message, metadata=None):
        self.code = code
        self.message = message
        self.metadata = dict(metadata or {})
        super().__init__(f"{code.name}: {message}")

    @property
    def code_name(self):
        """The status code's name, e.g. "NOT_FOUND"."""
        return self.code.name


def from_rpc_error(error):
    """The waymark.Error of a grpc.RpcError raised by a call (or a stream)."""
    code = error.code() if callable(getattr(error, "code", None)) else None
    if not isinstance(code, grpc.StatusCode):
        code = grpc.StatusCode.UNKNOWN
    details = error.details() if callable(getattr(error, "details", None)) else None
    trailing = ()
    if callable(getattr(error, "trailing_metadata", None)):
        trailing = error.trailing_metadata() or ()
    return Error(code, details if details is not None else str(error), trailing)


def invalid_argument(message):
    return Error(grpc.StatusCode.INVALID_ARGUMENT, message)

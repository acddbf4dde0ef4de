"""Channels as the C++ client makes them (client/lib/channel.h): keepalive for robots on Wi-Fi,
a short reconnect backoff, 64 MiB messages, TLS from PEM files, and the bearer token sent as
"authorization: Bearer <token>" on every call by an interceptor (gRPC refuses call credentials
over plaintext, which the loopback development setup uses).
"""
import collections
import ipaddress
import os
import random
import socket

import grpc

from waymark.errors import Error, invalid_argument

DEFAULT_PORT = 50051  # as the command line (client/cli/server_address.h)

# client/lib/channel.h, ChannelOptions: the keepalive must agree with the server's ping policy
# (server/service/runtime/server_channel.h), or the server answers GOAWAY "too_many_pings".
_CHANNEL_OPTIONS = [
    ("grpc.keepalive_time_ms", 30_000),
    ("grpc.keepalive_timeout_ms", 20_000),
    ("grpc.keepalive_permit_without_calls", 1),
    ("grpc.http2.max_pings_without_data", 0),
    ("grpc.max_reconnect_backoff_ms", 10_000),
    ("grpc.initial_reconnect_backoff_ms", 250),
    ("grpc.max_send_message_length", 64 * 1024 * 1024),
    ("grpc.max_receive_message_length", 64 * 1024 * 1024),
]


def _split_host_port(entry):
    """("host", port or None) of "host", "host:port", "[v6]", "[v6]:port" or a bare IPv6."""
    if entry.startswith("["):
        close = entry.find("]")
        if close < 0:
            raise invalid_argument(f"server address {entry!r}: '[' without ']'")
        host, rest = entry[1:close], entry[close + 1:]
        if rest and not rest.startswith(":"):
            raise invalid_argument(f"server address {entry!r}: expected ':PORT' after ']'")
        return host, (rest[1:] or None) if rest else None
    if entry.count(":") > 1:  # a bare IPv6 address has no port
        return entry, None
    host, _, port = entry.partition(":")
    return host, (port or None)


def _with_port(host, port):
    if port is not None and not (port.isdigit() and 0 < int(port) < 65536):
        raise invalid_argument(f"server address: port {port!r} is not a number in 1-65535")
    port = port or str(DEFAULT_PORT)
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


def resolve_target(address):
    """(gRPC target, round_robin, first host) for `address`.

    One server: "host", "host:port", "[v6]:port" (port 50051 if omitted), or any gRPC target URI
    ("unix:PATH", "dns:///name:port", "ipv4:a:p,b:p"), left as it is. Several servers sharing a
    PostgreSQL database: "a:50051,b,10.0.0.3:6000", resolved now into one ipv4:/ipv6: list that
    gRPC's round_robin spreads calls over (client/lib/fleet_target.h), starting at a random one
    so that a fleet of robots does not all begin on the first.
    """
    address = address.strip()
    if not address:
        raise invalid_argument("server address is empty")
    if address.startswith(("unix:", "unix-abstract:", "dns:", "ipv4:", "ipv6:")):
        return address, address.startswith(("ipv4:", "ipv6:")) and "," in address, ""
    entries = [e.strip() for e in address.split(",")]
    if len(entries) == 1:
        host, port = _split_host_port(entries[0])
        return _with_port(host, port), False, host
    if not all(entries):
        raise invalid_argument(f"server list {address!r} has an empty entry")
    resolved, families = [], set()
    for entry in entries:
        host, port = _split_host_port(entry)
        port = int(_with_port(host, port).rsplit(":", 1)[1])
        try:
            ipaddress.ip_address(host)
            infos = [(socket.AF_INET6 if ":" in host else socket.AF_INET, host)]
        except ValueError:
            try:
                infos = [(i[0], i[4][0])
                         for i in socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)]
            except socket.gaierror as e:
                raise Error(grpc.StatusCode.NOT_FOUND,
                            f"server {host!r} does not resolve: {e}") from e
        family, ip = infos[0]
        families.add(family)
        resolved.append(f"[{ip}]:{port}" if family == socket.AF_INET6 else f"{ip}:{port}")
    if len(families) > 1:
        raise invalid_argument(f"server list {address!r} mixes IPv4 and IPv6 servers")
    first = random.randrange(len(resolved))
    resolved = resolved[first:] + resolved[:first]
    scheme = "ipv6:" if families == {socket.AF_INET6} else "ipv4:"
    return scheme + ",".join(resolved), True, _split_host_port(entries[0])[0]


def _read_pem(path, what):
    try:
        with open(os.fspath(path), "rb") as f:
            data = f.read()
    except OSError as e:
        raise Error(grpc.StatusCode.NOT_FOUND,
                    f"cannot read the {what} file {path}: {e.strerror}") from e
    if b"-----BEGIN " not in data:
        raise invalid_argument(f"the {what} file {path} is not PEM (no -----BEGIN line)")
    return data


def tls_credentials(ca_file=None, cert_file=None, key_file=None):
    """TLS channel credentials: `ca_file` verifies the server (None = the system's roots);
    `cert_file` and `key_file` are the client's own certificate (both or neither)."""
    if (cert_file is None) != (key_file is None):
        raise invalid_argument("a client certificate needs its key (cert_file and key_file)")
    root = _read_pem(ca_file, "TLS CA") if ca_file else None
    cert = _read_pem(cert_file, "TLS client certificate") if cert_file else None
    key = _read_pem(key_file, "TLS client key") if key_file else None
    return grpc.ssl_channel_credentials(root_certificates=root, private_key=key,
                                        certificate_chain=cert)


class _CallDetails(collections.namedtuple(
        "_CallDetails", ("method", "timeout", "metadata", "credentials", "wait_for_ready",
                         "compression")), grpc.ClientCallDetails):
    pass


class _BearerToken(grpc.UnaryUnaryClientInterceptor, grpc.UnaryStreamClientInterceptor,
                   grpc.StreamUnaryClientInterceptor, grpc.StreamStreamClientInterceptor):
    """Adds "authorization: Bearer <token>" to every call, raw stubs' calls included."""

    def __init__(self, token):
        self._header = ("authorization", f"Bearer {token}")

    def _details(self, details):
        metadata = list(details.metadata or []) + [self._header]
        return _CallDetails(details.method, details.timeout, metadata, details.credentials,
                            getattr(details, "wait_for_ready", None),
                            getattr(details, "compression", None))

    def intercept_unary_unary(self, continuation, details, request):
        return continuation(self._details(details), request)

    def intercept_unary_stream(self, continuation, details, request):
        return continuation(self._details(details), request)

    def intercept_stream_unary(self, continuation, details, requests):
        return continuation(self._details(details), requests)

    def intercept_stream_stream(self, continuation, details, requests):
        return continuation(self._details(details), requests)


def make_channel(address, token=None, tls=False, ca_file=None, cert_file=None, key_file=None,
                 tls_server_name=None):
    """A channel to `address` (see resolve_target). TLS when `tls` is true or any PEM file is
    given (ca_file None: the system's roots). Connects lazily: a server that is down surfaces as
    UNAVAILABLE from the first call."""
    target, round_robin, host = resolve_target(address)
    options = list(_CHANNEL_OPTIONS)
    if round_robin:
        options.append(("grpc.lb_policy_name", "round_robin"))
    use_tls = bool(tls or ca_file or cert_file or key_file)
    if use_tls:
        if tls_server_name:
            options.append(("grpc.ssl_target_name_override", tls_server_name))
        elif round_robin and host:  # an ipv4: list has no host name; certificates carry names
            options.append(("grpc.ssl_target_name_override", host))
        channel = grpc.secure_channel(target, tls_credentials(ca_file, cert_file, key_file),
                                      options=options)
    else:
        if tls_server_name:
            raise invalid_argument("tls_server_name needs TLS (tls=True or ca_file)")
        channel = grpc.insecure_channel(target, options=options)
    if token:
        channel = grpc.intercept_channel(channel, _BearerToken(token))
    return channel

"""Streaming calls as generators: requests come from the caller's iterable (read by gRPC on its
own thread), answers are yielded as they arrive. An exception the caller's iterable raises (an
unreadable image, a bad scan) ends the call and is raised to the caller as it was, rather than
as gRPC's CANCELLED."""
import threading

import grpc

from waymark.errors import from_rpc_error


class RequestFeed:
    """Wraps a request generator for gRPC; remembers the exception that stopped it."""

    def __init__(self, generator):
        self._generator = generator
        self.error = None
        self.stopped = threading.Event()  # the caller is gone: stop producing

    def __iter__(self):
        return self

    def __next__(self):
        if self.stopped.is_set():
            raise StopIteration
        try:
            return next(self._generator)
        except StopIteration:
            raise
        except Exception as e:  # noqa: BLE001 - handed to the caller's thread
            self.error = e
            raise


def answers(call, feed, convert):
    """Yields convert(answer) for each answer of `call`; raises waymark.Error (or the feed's own
    exception); cancels the call when the caller stops early."""
    try:
        for answer in call:
            yield convert(answer)
        if feed.error is not None:
            raise feed.error
    except grpc.RpcError as e:
        if feed.error is not None:
            raise feed.error from None
        raise from_rpc_error(e) from None
    finally:
        feed.stopped.set()
        call.cancel()  # a no-op once the call has ended

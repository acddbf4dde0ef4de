"""What the helpers accept from callers: images as bytes or paths, parameters as messages or
dicts. Bad input gets a waymark.Error naming it before anything is sent."""
import os

import grpc
from google.protobuf import json_format

from waymark.errors import Error, invalid_argument
from waymark.typed import MODES


def image_bytes(image, what="image"):
    """The encoded bytes of `image`: bytes-like as is, str / os.PathLike read from the file."""
    if isinstance(image, (bytes, bytearray, memoryview)):
        data = bytes(image)
    elif isinstance(image, (str, os.PathLike)):
        try:
            with open(image, "rb") as f:
                data = f.read()
        except OSError as e:
            raise Error(grpc.StatusCode.NOT_FOUND,
                        f"cannot read the {what} file {os.fspath(image)}: {e.strerror}") from e
    else:
        raise invalid_argument(f"{what}: expected bytes or a file path, got {type(image).__name__}")
    if not data:
        raise invalid_argument(f"{what} is empty")
    return data


def _short_modes(value):
    """A copy of `value` with every recognition "mode": "paper" / "verified" / "retrieval"
    (at any depth, e.g. DatabaseParams.recognition.mode) given as its enum number."""
    if isinstance(value, dict):
        return {k: MODES[v.lower()] if k == "mode" and isinstance(v, str) and v.lower() in MODES
                else _short_modes(v) for k, v in value.items()}
    return value


def params_message(message_class, params, what):
    """`params` as a `message_class`: None, a message of that class, or a dict of its fields
    (proto or JSON names; for a recognition mode, "paper", "verified" or "retrieval" too)."""
    if params is None:
        return message_class()
    if isinstance(params, message_class):
        return params
    if not isinstance(params, dict):
        raise invalid_argument(f"{what}: expected a dict or a {message_class.__name__}, "
                               f"got {type(params).__name__}")
    try:
        return json_format.ParseDict(_short_modes(params), message_class())
    except json_format.ParseError as e:
        raise invalid_argument(f"{what}: {e}") from e

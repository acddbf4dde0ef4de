#!/usr/bin/env python3
"""Parses every answer `waymark-fuzz --answers FILE` wrote with Python's protobuf (issue 35).

A proto3 string field must hold valid UTF-8; Python's protobuf refuses a message that does not
(DecodeError, or UnicodeDecodeError from the pure-Python parser), and the client then loses the
whole answer. Every answer the services gave to the fuzz inputs must parse here. Answers must not
carry client text back unbounded either: no string field may be longer than --max-string bytes
(the services' status messages are cut at 1 KiB; quoted client text at 64-128 characters).

Usage: parse_answers.py FILE [FILE...] [--max-string N]
Exit 0: every answer parsed; 1: some did not (the first ones are printed); 77: no protobuf for
Python (install Debian's python3-protobuf; ctest reports the test as skipped).
"""
import struct
import sys

try:
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
    from google.protobuf.internal import api_implementation
except ImportError:
    print("parse_answers: no protobuf for Python (apt-get install python3-protobuf); skipped")
    sys.exit(77)


def message_class(pool, factory, name):
    descriptor = pool.FindMessageTypeByName(name)
    if hasattr(message_factory, "GetMessageClass"):  # protobuf 4.x
        return message_factory.GetMessageClass(descriptor)
    return factory.GetPrototype(descriptor)


def records(path):
    with open(path, "rb") as f:
        data = f.read()
    at = 0
    while at < len(data):
        (n,) = struct.unpack_from("<I", data, at)
        name = data[at + 4:at + 4 + n].decode("ascii")
        at += 4 + n
        (m,) = struct.unpack_from("<I", data, at)
        payload = data[at + 4:at + 4 + m]
        at += 4 + m
        yield name, payload


def longest_string(message):
    """The longest string field anywhere in `message` (bytes fields are not text)."""
    longest = 0
    for field, value in message.ListFields():
        values = value if field.label == field.LABEL_REPEATED else [value]
        for v in values:
            if field.type == field.TYPE_STRING:
                longest = max(longest, len(v.encode("utf-8")))
            elif field.type == field.TYPE_MESSAGE:
                longest = max(longest, longest_string(v))
    return longest


def check(path, max_string):
    fds = descriptor_pb2.FileDescriptorSet()
    with open(path + ".fds", "rb") as f:
        fds.ParseFromString(f.read())
    pool = descriptor_pool.DescriptorPool()
    for file in fds.file:
        pool.Add(file)
    factory = message_factory.MessageFactory(pool) if not hasattr(
        message_factory, "GetMessageClass") else None
    classes = {}
    total = 0
    failures = []
    for name, payload in records(path):
        total += 1
        if name not in classes:
            classes[name] = message_class(pool, factory, name)
        message = classes[name]()
        try:
            message.ParseFromString(payload)
        except Exception as e:  # DecodeError (upb, cpp) or UnicodeDecodeError (pure Python)
            failures.append("%s (%d bytes) does not parse: %s: %s; bytes %r" %
                            (name, len(payload), type(e).__name__, e, payload[:200]))
            continue
        longest = longest_string(message)
        if longest > max_string:
            failures.append("%s carries a string of %d bytes (at most %d)" %
                            (name, longest, max_string))
    print("%s: %d answers, %d refused (python protobuf %s)" %
          (path, total, len(failures), api_implementation.Type()))
    for failure in failures[:10]:
        print("  " + failure)
    return total, failures


def main(argv):
    max_string = 4096
    paths = []
    i = 0
    while i < len(argv):
        if argv[i] == "--max-string":
            max_string = int(argv[i + 1])
            i += 2
        else:
            paths.append(argv[i])
            i += 1
    if not paths:
        print(__doc__)
        return 2
    bad = 0
    for path in paths:
        total, failures = check(path, max_string)
        if total == 0:
            print("%s: no answers at all: the target did not run" % path)
            bad += 1
        bad += len(failures)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

#!/usr/bin/env python3
"""Recognizes one image against a crossing database: which crossing, which way the camera faced.

    PYTHONPATH=python:build/python python3 python/examples/recognize_image.py \
        --server 127.0.0.1:50051 city photo.jpg

The database is made and filled by `waymark db create` and `waymark enroll` (or by
client.create_database / client.enroll). A server with authentication needs --token (or
WAYMARK_TOKEN); TLS: --tls-ca (or WAYMARK_TLS_CA).
"""
import argparse
import os
import sys

import waymark


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("database")
    parser.add_argument("image", nargs="+", help="JPEG or PNG files")
    parser.add_argument("--server", default=os.environ.get("WAYMARK_SERVER", "127.0.0.1:50051"))
    parser.add_argument("--token", default=os.environ.get("WAYMARK_TOKEN"))
    parser.add_argument("--tls-ca", default=os.environ.get("WAYMARK_TLS_CA"))
    parser.add_argument("--mode", choices=("paper", "verified", "retrieval"),
                        help="recognition mode (default: the database's)")
    args = parser.parse_args()

    client = waymark.connect(args.server, token=args.token, ca_file=args.tls_ca)
    params = {"mode": args.mode} if args.mode else None
    try:
        for image in args.image:
            answer = client.recognize(args.database, image, params=params)
            if not answer.accepted:
                print(f"{image}: not recognized ({answer.reason})")
                continue
            heading = "unknown" if answer.heading_deg is None else f"{answer.heading_deg:g} deg"
            nfa = "" if answer.log10_nfa is None else f", log10 NFA {answer.log10_nfa:.1f}"
            print(f"{image}: crossing {answer.crossing}, heading {heading} "
                  f"(accepted by {answer.accepted_by}{nfa}; {answer.total_ms:.0f} ms)")
    except waymark.Error as e:
        sys.exit(f"error: {e}")


if __name__ == "__main__":
    main()

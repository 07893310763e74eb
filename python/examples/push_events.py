#!/usr/bin/env python3
"""Prints the events the viewer pushes (server-sent events from `/events`), one JSON
line each: gestures, and with --skeletons HZ skeletons. Standard library only.

    python3 python/examples/push_events.py --url http://127.0.0.1:8080 [--count N]

A `lagged` line says how many events this reader was too slow for: nothing is dropped
without a word.
"""

import argparse
import json
import sys
import urllib.request


def events(url):
    """(event, data) pairs of a server-sent event stream."""
    with urllib.request.urlopen(url, timeout=30) as stream:
        kind, data = None, []
        for raw in stream:
            line = raw.decode("utf-8").rstrip("\r\n")
            if not line:
                if kind and data:
                    yield kind, "\n".join(data)
                kind, data = None, []
            elif line.startswith("event:"):
                kind = line[6:].strip()
            elif line.startswith("data:"):
                data.append(line[5:].strip())


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--url", default="http://127.0.0.1:8080")
    parser.add_argument("--skeletons", type=float, default=0, help="skeletons a second")
    parser.add_argument("--count", type=int, help="stop after this many gestures")
    args = parser.parse_args()
    url = f"{args.url}/events?stats=0&skeletons={args.skeletons:g}"
    left = args.count
    for kind, data in events(url):
        line = json.loads(data)
        if kind == "lagged":
            line = {"event": "lagged", **line}
        print(json.dumps(line), flush=True)
        if kind == "gesture" and left is not None:
            left -= 1
            if left == 0:
                return 0
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except KeyboardInterrupt:
        sys.exit(130)

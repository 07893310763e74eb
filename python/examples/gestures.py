#!/usr/bin/env python3
"""Prints each gesture a running airglyph pipeline recognizes, one JSON line each (the
keys of `airglyph run --json`), the last ones it kept first.

    PYTHONPATH=python python3 python/examples/gestures.py [--count N]

Needs `pip install "iceoryx2==0.10.*"`, and the pipeline's user and AIRGLYPH_IPC_*.
"""

import argparse
import json
import signal
import sys

from airglyph import pipeline

stop = False


def on_signal(_sig, _frame):
    global stop
    stop = True


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, help="stop after this many gestures")
    args = parser.parse_args()
    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    try:
        node = pipeline.join("python-gestures")
    except pipeline.NotRunning as e:
        print(f"gestures.py: {e}", file=sys.stderr)
        return 1
    gestures = pipeline.gestures(node)
    printed = pipeline.Printed()
    left = args.count
    while not stop and left != 0:
        g = gestures.receive(0.1)
        if g is None or not printed.first_time(g):
            continue
        print(json.dumps(pipeline.gesture_dict(g)), flush=True)
        if left is not None:
            left -= 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

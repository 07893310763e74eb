"""The pipeline's wire types as ctypes structures.

Each mirrors a `#[repr(C)]` struct of `shared/ipc/src/wire.rs` field for field and
carries its iceoryx2 type name, so iceoryx2 refuses to connect a Python subscriber to a
publisher whose layout changed (the Rust side raises the `.vN` with the layout).
`tests/tests/python.rs` compares every offset and size here with the Rust layout.

This module needs only the standard library: `layout()` can be checked without the
iceoryx2 bindings installed.
"""

import ctypes
import json
import sys

JOINTS = (
    "head", "neck", "torso", "pelvis",
    "left_shoulder", "left_elbow", "left_hand",
    "right_shoulder", "right_elbow", "right_hand",
    "left_hip", "left_knee", "left_foot",
    "right_hip", "right_knee", "right_foot",
)
"""The 16 joints in index order, the order of every array on the wire."""

LABEL_CAPACITY = 32
"""Longest gesture label on the wire, in UTF-8 bytes."""
BEZIER_CAPACITY = 64
"""Most Bezier points a gesture event carries."""
POSTURE_LABEL_CAPACITY = 16
"""Longest posture label on the wire, in UTF-8 bytes."""
HANDS = ("left", "right")
"""The hands in index order, the order of a skeleton's postures."""


def _bounded_text(raw, n, capacity):
    """The first n bytes of raw as text, or None when n is out of range or the bytes
    are not UTF-8 (what the Rust receivers refuse)."""
    if n > capacity:
        return None
    try:
        return bytes(raw[:n]).decode("utf-8")
    except UnicodeDecodeError:
        return None


class _Wire(ctypes.Structure):
    """A wire type: its iceoryx2 type name is the class attribute `TYPE_NAME`."""

    TYPE_NAME = ""

    @classmethod
    def type_name(cls) -> str:
        """The iceoryx2 type name, as the Rust side's `#[type_name(...)]`."""
        return cls.TYPE_NAME


class LatencyChain(_Wire):
    """Each stage's in and out times of one frame, CLOCK_MONOTONIC ns; 0 = not reached."""

    TYPE_NAME = "airglyph.LatencyChain.v1"
    _fields_ = [
        ("capture_ns", ctypes.c_uint64),
        ("capture_publish_ns", ctypes.c_uint64),
        ("pose_receive_ns", ctypes.c_uint64),
        ("pose_publish_ns", ctypes.c_uint64),
        ("gesture_receive_ns", ctypes.c_uint64),
        ("gesture_publish_ns", ctypes.c_uint64),
    ]


class DepthHeader(_Wire):
    """The user header of a depth frame (`airglyph/depth`); the payload is u16 mm."""

    TYPE_NAME = "airglyph.DepthHeader.v1"
    _fields_ = [
        ("sequence", ctypes.c_uint64),
        ("session", ctypes.c_uint64),
        ("capture_ns", ctypes.c_uint64),
        ("publish_ns", ctypes.c_uint64),
        ("source_ns", ctypes.c_uint64),
        ("width", ctypes.c_uint32),
        ("height", ctypes.c_uint32),
        ("fx", ctypes.c_float),
        ("fy", ctypes.c_float),
        ("cx", ctypes.c_float),
        ("cy", ctypes.c_float),
        ("source_kind", ctypes.c_uint32),
        ("flags", ctypes.c_uint32),
    ]


class PostureMsg(_Wire):
    """One hand's static posture in a skeleton; label_len 0 when it was not classified."""

    TYPE_NAME = "airglyph.PostureMsg.v1"
    _fields_ = [
        ("label", ctypes.c_uint8 * POSTURE_LABEL_CAPACITY),
        ("label_len", ctypes.c_uint32),
        ("confidence", ctypes.c_float),
    ]

    def posture(self):
        """(label, confidence), or None when the hand was not classified or what was
        written is not a posture (the Rust receivers refuse such a skeleton)."""
        if self.label_len == 0 or not 0.0 <= self.confidence <= 1.0:
            return None
        label = _bounded_text(self.label, self.label_len, POSTURE_LABEL_CAPACITY)
        return None if label is None else (label, self.confidence)


class SkeletonMsg(_Wire):
    """The skeleton of one depth frame (`airglyph/skeleton`): metres, camera frame."""

    TYPE_NAME = "airglyph.SkeletonMsg.v3"
    _fields_ = [
        ("sequence", ctypes.c_uint64),
        ("session", ctypes.c_uint64),
        ("chain", LatencyChain),
        ("joints", (ctypes.c_float * 3) * len(JOINTS)),
        ("confidence", ctypes.c_float * len(JOINTS)),
        ("person_found", ctypes.c_uint8),
        ("_pad", ctypes.c_uint8),
        ("visible", ctypes.c_uint16),
        ("_reserved", ctypes.c_uint8 * 4),
        ("postures", PostureMsg * len(HANDS)),
    ]

    def posture(self, hand):
        """The posture of hand ("left" or "right") as (label, confidence), or None."""
        return self.postures[HANDS.index(hand)].posture()


class GestureEventMsg(_Wire):
    """A spotted and classified gesture (`airglyph/gesture`)."""

    TYPE_NAME = "airglyph.GestureEventMsg.v3"
    _fields_ = [
        ("label", ctypes.c_uint8 * LABEL_CAPACITY),
        ("label_len", ctypes.c_uint32),
        ("score", ctypes.c_float),
        ("start_sequence", ctypes.c_uint64),
        ("end_sequence", ctypes.c_uint64),
        ("start_ns", ctypes.c_uint64),
        ("end_ns", ctypes.c_uint64),
        ("session", ctypes.c_uint64),
        ("chain", LatencyChain),
        ("hand", ctypes.c_uint8),
        ("_reserved", ctypes.c_uint8 * 3),
        ("bezier_len", ctypes.c_uint32),
        ("bezier", (ctypes.c_float * 2) * BEZIER_CAPACITY),
        ("posture", ctypes.c_uint8 * POSTURE_LABEL_CAPACITY),
        ("posture_len", ctypes.c_uint32),
        ("_reserved_end", ctypes.c_uint8 * 4),
    ]

    def bezier_points(self):
        """The Bezier points of the path the gesture was recognized from (body frame,
        shoulder widths), or None when their count is out of range."""
        n = self.bezier_len
        if n > BEZIER_CAPACITY:
            return None
        return [(self.bezier[i][0], self.bezier[i][1]) for i in range(n)]

    def label_text(self):
        """The label, or None when it is not UTF-8 of at most LABEL_CAPACITY bytes
        (what the Rust receivers refuse too)."""
        return _bounded_text(self.label, self.label_len, LABEL_CAPACITY)

    def posture_text(self):
        """The posture the drawing hand held over most of the gesture, or None when it
        is unknown or not UTF-8 of at most POSTURE_LABEL_CAPACITY bytes."""
        if self.posture_len == 0:
            return None
        return _bounded_text(self.posture, self.posture_len, POSTURE_LABEL_CAPACITY)


class DecisionMsg(_Wire):
    """The gesture stage's decision on one frame (`airglyph/decision`)."""

    TYPE_NAME = "airglyph.DecisionMsg.v2"
    _fields_ = [
        ("sequence", ctypes.c_uint64),
        ("session", ctypes.c_uint64),
        ("chain", LatencyChain),
        ("hand_point", ctypes.c_float * 2),
        ("gesture", ctypes.c_uint8),
        ("hand_found", ctypes.c_uint8),
        ("hand", ctypes.c_uint8),
        ("_reserved", ctypes.c_uint8 * 5),
    ]


class Percentiles(_Wire):
    """Percentiles of one latency distribution over the last window, in ns."""

    TYPE_NAME = "airglyph.Percentiles.v1"
    _fields_ = [
        ("count", ctypes.c_uint64),
        ("p50", ctypes.c_uint64),
        ("p90", ctypes.c_uint64),
        ("p99", ctypes.c_uint64),
        ("max", ctypes.c_uint64),
    ]


class StageStatsMsg(_Wire):
    """One stage's telemetry, once a second (`airglyph/stats/<stage>`)."""

    TYPE_NAME = "airglyph.StageStatsMsg.v1"
    _fields_ = [
        ("stage", ctypes.c_uint32),
        ("pid", ctypes.c_uint32),
        ("time_ns", ctypes.c_uint64),
        ("window_ns", ctypes.c_uint64),
        ("frames_in", ctypes.c_uint64),
        ("frames_out", ctypes.c_uint64),
        ("frames_dropped", ctypes.c_uint64),
        ("frames_rejected", ctypes.c_uint64),
        ("fps", ctypes.c_float),
        ("_reserved", ctypes.c_uint32),
        ("processing", Percentiles),
        ("waiting", Percentiles),
        ("latency", Percentiles),
    ]


TYPES = (LatencyChain, DepthHeader, PostureMsg, SkeletonMsg, GestureEventMsg,
         DecisionMsg, Percentiles, StageStatsMsg)


def layout():
    """Every type's name, size, alignment and fields' offsets and sizes."""
    out = {}
    for t in TYPES:
        fields = {}
        for name, ctype in t._fields_:
            fields[name] = [getattr(t, name).offset, ctypes.sizeof(ctype)]
        out[t.__name__] = {
            "type_name": t.type_name(),
            "size": ctypes.sizeof(t),
            "align": ctypes.alignment(t),
            "fields": fields,
        }
    return out


if __name__ == "__main__":
    # `python3 -m airglyph.wire`: the layout as JSON, for the test that compares it with Rust's.
    json.dump(layout(), sys.stdout, sort_keys=True)
    print()

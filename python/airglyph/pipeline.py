"""Joining a running airglyph pipeline from Python, through iceoryx2's own bindings
(`pip install "iceoryx2==0.10.*"`, the version airglyph is built with).

The pipeline is the one the environment names, as for every airglyph process:
AIRGLYPH_IPC_ROOT (default /tmp/airglyph/) and AIRGLYPH_IPC_PREFIX (default airglyph_),
or `[ipc] root`/`prefix` in the TOML file named by AIRGLYPH_CONFIG; the rest of the
iceoryx2 settings come from iceoryx2's own file where iceoryx2 looks for it, as in
`shared/ipc/src/site.rs`.
"""

import os
import stat

import iceoryx2 as iox2

from . import wire

DEFAULT_ROOT = "/tmp/airglyph/"
DEFAULT_PREFIX = "airglyph_"

GESTURE_HISTORY = 8
"""Gesture events the gesture stage keeps for a late subscriber (`GESTURE_HISTORY`)."""


class NotRunning(Exception):
    """The pipeline named by the environment is not there, or is not this user's."""


def settings():
    """The pipeline's root folder and prefix, as airglyph reads them."""
    root, prefix = DEFAULT_ROOT, DEFAULT_PREFIX
    path = os.environ.get("AIRGLYPH_CONFIG")
    if path:
        import tomllib

        with open(path, "rb") as f:
            ipc = tomllib.load(f).get("ipc", {})
        root, prefix = ipc.get("root", root), ipc.get("prefix", prefix)
    root = os.environ.get("AIRGLYPH_IPC_ROOT", root)
    prefix = os.environ.get("AIRGLYPH_IPC_PREFIX", prefix)
    if not root.endswith("/"):
        root += "/"
    return root, prefix


def _site_file():
    """iceoryx2's own configuration file, where iceoryx2 looks for it."""
    places = [os.path.join("config", "iceoryx2.toml")]
    home = os.environ.get("HOME")
    if home:
        places.append(os.path.join(home, ".config", "iceoryx2", "iceoryx2.toml"))
    places.append("/etc/iceoryx2/iceoryx2.toml")
    return next((p for p in places if os.path.isfile(p)), None)


def _check_root(root):
    """A pipeline's root folder is made by its first stage, closed to other users: join
    only one that exists and is ours (joining first would make it, and iceoryx2's node
    counter, open to everyone)."""
    try:
        st = os.lstat(root)
    except FileNotFoundError:
        raise NotRunning(f"{root}: no pipeline here; start it first (airglyph run)") from None
    if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.geteuid() or st.st_mode & 0o077:
        raise NotRunning(
            f"{root}: not a folder of this user's closed to others; join as the pipeline's user"
        )


def config():
    """The iceoryx2 configuration of the pipeline."""
    root, prefix = settings()
    _check_root(root)
    site = _site_file()
    cfg = iox2.config.from_file(iox2.FilePath.new(site)) if site else iox2.config.default()
    cfg.global_cfg.root_path = iox2.Path.new(root)
    cfg.global_cfg.prefix = iox2.FileName.new(prefix)
    return cfg


def join(name):
    """Joins the pipeline as the iceoryx2 node `name`."""
    return (
        iox2.NodeBuilder.new()
        .name(iox2.NodeName.new(name))
        .config(config())
        .signal_handling_mode(iox2.SignalHandlingMode.Disabled)
        .create(iox2.ServiceType.Ipc)
    )


class Receiver:
    """A subscriber of one of the pipeline's services, woken by the service's event."""

    def __init__(self, node, service, payload, history=0, buffer=None):
        name = iox2.ServiceName.new(service)
        self._service = node.service_builder(name).publish_subscribe(payload).open()
        builder = self._service.subscriber_builder()
        if buffer is not None:
            builder = builder.buffer_size(buffer)
        self._subscriber = builder.history_request(history).create()
        self._events = node.service_builder(name).event().open_or_create()
        self._listener = self._events.listener_builder().create()

    def receive(self, timeout_s):
        """The next message (a copy), or None when none came within `timeout_s`."""
        sample = self._subscriber.receive()
        if sample is None:
            try:
                self._listener.timed_wait(iox2.Duration.from_secs_f64(timeout_s))
            except iox2.ListenerWaitError as e:
                # A signal (Ctrl-C, SIGTERM) woke the wait: the program's handler has
                # run, and the caller decides whether to stop; anything else is an error.
                if str(e) != "InterruptSignal":
                    raise
            sample = self._subscriber.receive()
        if sample is None:
            return None
        # A copy: the sample's memory goes back to the publisher when it is released.
        msg = type(sample.payload().contents).from_buffer_copy(sample.payload().contents)
        sample.delete()
        return msg


def gestures(node, history=True):
    """A receiver of gesture events; with `history`, first the last ones kept."""
    return Receiver(node, "airglyph/gesture", wire.GestureEventMsg,
                    history=GESTURE_HISTORY if history else 0, buffer=128)


def skeletons(node):
    """A receiver of skeletons, one a depth frame."""
    return Receiver(node, "airglyph/skeleton", wire.SkeletonMsg, buffer=4)


class Printed:
    """Tells each gesture apart from one sent again: a restarted gesture stage may send
    the last one it sent before it died again. Within a capture session a gesture ends
    after the last one reported, so one that does not was seen already."""

    def __init__(self):
        self._last_end = {}

    def first_time(self, g):
        last = self._last_end.get(g.session)
        if last is not None and g.end_sequence <= last:
            return False
        self._last_end[g.session] = g.end_sequence
        if len(self._last_end) > 16:
            self._last_end.pop(next(iter(self._last_end)))
        return True


def gesture_dict(g):
    """A gesture with the keys of `airglyph run --json`."""
    return {
        "event": "gesture",
        "label": g.label_text() or "?",
        "score": g.score,
        "start_frame": g.start_sequence,
        "end_frame": g.end_sequence,
        "hand": "left" if g.hand == 0 else "right",
        "start_ns": g.start_ns,
        "end_ns": g.end_ns,
        "session": g.session,
        "latency_ms": max(0, g.chain.gesture_publish_ns - g.chain.capture_ns) * 1e-6,
        "posture": g.posture_text(),
    }

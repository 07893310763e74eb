#!/usr/bin/env python3
"""End to end, the pen lifted by the hand: a synthetic person draws symbols pointing and
opens the hand between them (`airglyph synth --pen-posture point,open`), the pose stage's
estimator and posture step read every frame (`airglyph pose --json`, the built-in
posture model), and the gesture stage's spotter runs over those skeletons with each pen
(`airglyph spot --poses FILE --pen motion|posture|gated`, the built-in gesture model).

Prints, per scene and symbol set: how often the drawing hand's posture was read right
while drawing (truth: point) and between symbols (truth: open), from hands.csv; then per
pen the symbols found (spotted with the right label), substituted (spotted, every label
wrong), missed (nothing spotted over them) and the false alarms (gestures over no
symbol). The posture and gated pens also run on the exact postures (hands.csv in place
of the posture step's, rows "posture exact", "gated exact"), to tell the posture step's
misreads from what the pen itself does. With LIVE=1 in the environment each pen also
runs through the real processes (`airglyph run --pen PEN --json --source
recording:DIR`, in real time), rows "PEN live". A JSON line a row goes to OUT (default
pen-e2e.jsonl).

usage: [LIVE=1] pen_e2e.py AIRGLYPH [OUT [SYNTH_ARGS...]]
SYNTH_ARGS go to every `airglyph synth`, e.g. `--body makehuman --body-shape
gender=0,height=0.45` for a body the built-in posture model was not trained on.
"""
import csv
import glob
import json
import os
import shutil
import subprocess
import sys
import tempfile

AIRGLYPH = sys.argv[1] if len(sys.argv) > 1 else "airglyph"
OUT = sys.argv[2] if len(sys.argv) > 2 else "pen-e2e.jsonl"
EXTRA = sys.argv[3:]
SCENES = [
    ("1.2 m upper body", ["--framing", "upper-body", "--distance", "1.2"]),
    ("2 m", ["--distance", "2"]),
]
SETS = [
    ("digits", "0123456789", 1),
    ("digits", "0123456789", 2),
    ("letters", "ABCDEFGHIJKLMNOPQRSTUVWXYZ", 1),
]
PENS = ["motion", "posture", "gated"]


def postures_read(rec, poses):
    """(right, frames) while drawing and between, from hands.csv's truth."""
    truth = {}
    with open(os.path.join(rec, "hands.csv")) as f:
        for row in csv.DictReader(f):
            if row["hand"] == "right":
                truth[int(row["frame"])] = row["posture"]
    counts = {"drawing": [0, 0], "between": [0, 0]}
    read_as = {"drawing": {}, "between": {}}
    for line in poses.splitlines():
        fr = json.loads(line)
        want = truth[fr["frame"]]
        part = "drawing" if want == "point" else "between"
        got = ((fr.get("postures") or {}).get("right") or {}).get("label", "none")
        counts[part][0] += got == want
        counts[part][1] += 1
        read_as[part][got] = read_as[part].get(got, 0) + 1
    return counts, read_as


def exact_poses(rec, poses, path):
    """`poses` with the right hand's posture replaced by the truth of hands.csv."""
    with open(os.path.join(rec, "hands.csv")) as f:
        truth = {int(r["frame"]): r["posture"] for r in csv.DictReader(f)
                 if r["hand"] == "right"}
    with open(path, "w") as out:
        for line in poses.splitlines():
            fr = json.loads(line)
            fr["postures"] = {"left": None,
                              "right": {"label": truth[fr["frame"]], "confidence": 1.0}}
            out.write(json.dumps(fr) + "\n")


def overlapped(spans, start, end):
    """The symbol whose frames the gesture's overlap most (as `spot` decides), or None."""
    best, most = None, 0
    for i, (s, e) in enumerate(spans):
        o = min(e, end) - max(s, start)
        if o > most:
            best, most = i, o
    return best


def spot(rec, poses_file, pen, live=False):
    if live:
        # The isolated pipeline of this run: its own folder and prefix.
        ipc = tempfile.mkdtemp()
        env = dict(os.environ, AIRGLYPH_IPC_ROOT=ipc + "/",
                   AIRGLYPH_IPC_PREFIX=f"pen_e2e_{os.getpid()}")
        out = subprocess.run(
            [AIRGLYPH, "run", "--pen", pen, "--json", "--source", f"recording:{rec}"],
            check=True, capture_output=True, text=True, env=env).stdout
        shutil.rmtree(ipc, ignore_errors=True)
        # iceoryx2 leaves its management file behind when the pipeline has ended.
        for leftover in glob.glob(f"/dev/shm/{env['AIRGLYPH_IPC_PREFIX']}*"):
            os.remove(leftover)
    else:
        out = subprocess.run(
            [AIRGLYPH, "spot", rec, "--poses", poses_file, "--pen", pen, "--json"],
            check=True, capture_output=True, text=True).stdout
    with open(os.path.join(rec, "gestures.csv")) as f:
        rows = list(csv.DictReader(f))
    drawn = [g["label"] for g in rows]
    spans = [(int(g["start_frame"]), int(g["end_frame"])) for g in rows]
    found, spotted_over, false_alarms, in_point = set(), set(), 0, 0
    gestures = [json.loads(l) for l in out.splitlines() if l.startswith("{")]
    gestures = [g for g in gestures if g["event"] == "gesture"]
    for g in gestures:
        in_point += g.get("posture") == "point"
        best = overlapped(spans, g["start_frame"], g["end_frame"])
        if best is None:
            false_alarms += 1
            continue
        spotted_over.add(best)
        if g["label"] == drawn[best]:
            found.add(best)
    n = len(drawn)
    return {
        "drawn": n,
        "found": len(found),
        "substituted": len(spotted_over - found),
        "missed": n - len(spotted_over),
        "false_alarms": false_alarms,
        "gestures": len(gestures),
        "gestures_in_point": in_point,
    }


with tempfile.TemporaryDirectory() as tmp, open(OUT, "w") as log:
    for scene, args in SCENES:
        for set_name, symbols, seed in SETS:
            rec = os.path.join(tmp, "rec")
            subprocess.run(["rm", "-rf", rec], check=True)
            subprocess.run(
                [AIRGLYPH, "synth", "--out", rec, "--motion", f"draw:{symbols}",
                 "--pen-posture", "point,open", "--noise", "--seed", str(seed)]
                + args + EXTRA, check=True, stdout=subprocess.DEVNULL)
            poses = subprocess.run([AIRGLYPH, "pose", rec, "--json"], check=True,
                                   capture_output=True, text=True).stdout
            poses_file = os.path.join(tmp, "poses.jsonl")
            with open(poses_file, "w") as f:
                f.write(poses)
            counts, read_as = postures_read(rec, poses)
            d, b = counts["drawing"], counts["between"]
            print(f"{scene}, {set_name} seed {seed}: posture read right drawing "
                  f"{d[0]}/{d[1]} {100 * d[0] / d[1]:.1f}%, between {b[0]}/{b[1]} "
                  f"{100 * b[0] / b[1]:.1f}%")
            for part in ("drawing", "between"):
                seen = ", ".join(f"{k} {v}" for k, v in
                                 sorted(read_as[part].items(), key=lambda kv: -kv[1]))
                print(f"    read while {part}: {seen}")
            exact_file = os.path.join(tmp, "exact.jsonl")
            exact_poses(rec, poses, exact_file)
            runs = [(pen, pen, poses_file, False) for pen in PENS]
            runs += [(f"{pen} exact", pen, exact_file, False) for pen in PENS[1:]]
            if os.environ.get("LIVE") == "1":
                runs += [(f"{pen} live", pen, None, True) for pen in PENS]
            for name, pen, file, live in runs:
                r = spot(rec, file, pen, live)
                print(f"    pen {name:<14} found {r['found']:>2}/{r['drawn']:<2} substituted "
                      f"{r['substituted']:>2} missed {r['missed']:>2} false alarms "
                      f"{r['false_alarms']:>2} ({r['gestures_in_point']}/{r['gestures']} "
                      f"gestures drawn in point)")
                row = {"scene": scene, "set": set_name, "seed": seed, "pen": name,
                       "posture_drawing": d, "posture_between": b, **r}
                log.write(json.dumps(row) + "\n")
                log.flush()
            sys.stdout.flush()

#!/usr/bin/env python3
"""`capsflow render` with the real renderer: ParaView's pvbatch (under xvfb-run without a display) and ffmpeg.

A tiny run (4 capsules of mesh level 1, two species, to strain 1 with a frame every 0.25: 5 frames; about 2 s on one
core) is made with the built capsflow, then drawn three times:

- the last frame, coloured by species: a PNG of the size asked for, mostly the white background, with pixels of both
  species' colours (matplotlib's tab:blue and tab:red, shaded); the ParaView state beside it, an XML file that
  reads the run's XDMF index;
- a movie coloured by tension_max with frame 0 as a picture: an H.264 MP4 with one frame per run frame, of the size and
  frame rate asked for (ffprobe counts the decoded frames); the picture has the colour map's (non-grey) pixels;
- a movie of every second frame (3 frames); the same command again is refused without --force (status 2, one line,
  nothing changed);
- the last frame in each --view (side, top, oblique): every picture has both species' colours and the dark box, bar
  and labels, no two are alike, the title (in the saved state) names the file, X_f and each species' Ca and count,
  and an unknown view is refused (status 2, nothing written);
- a second run with a capsule across x = 0 and one across the corner x = Lx, z = Lz: in the side view every capsule
  pixel lies within the box's drawn edges, with pieces at both of its sides (the capsules cut at the periodic box).

Without pvbatch (or ffmpeg, or a display and xvfb-run) the test is skipped (exit 77) unless CAPSFLOW_REQUIRE_RENDER=1,
which tools/test.sh (CI) sets after installing them, so that CI cannot pass by skipping it.

    tests/python/test_render.py CAPSFLOW_BINARY WORKDIR     # as ctest runs it
"""

import json
import os
import shutil
import subprocess
import sys
import tempfile
import unittest
import xml.etree.ElementTree as ET

SKIP = 77
HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE_DIR = os.path.dirname(os.path.dirname(HERE))
BINARY = os.environ.get("CAPSFLOW_BINARY") or os.path.join(SOURCE_DIR, "build", "release", "capsflow")
WORKDIR = None

try:
    import numpy as np
    import matplotlib.image as mpimg
    MISSING = None
except ImportError as e:  # pragma: no cover - depends on the machine
    MISSING = str(e)

import tiny_run  # noqa: E402  (the shared tiny run: tests/python/tiny_run.py)

SPECIES = ["stiff", "floppy", "floppy", "stiff"]
CENTRES = [[1.5, 1.5, 1.5], [4.4, 2.2, 1.6], [1.6, 3.9, 4.5], [4.5, 4.4, 4.4]]
CONFIG = tiny_run.config(1.0, 0.05, 0.25, species=SPECIES, centres=CENTRES)
FRAMES = 5
_made = {}


def missing_tools():
    """What the real render path needs and this machine lacks (empty when nothing)."""
    lack = [p for p in ("pvbatch", "ffmpeg", "ffprobe") if shutil.which(p) is None]
    if not os.environ.get("DISPLAY") and shutil.which("xvfb-run") is None:
        lack.append("xvfb-run (no DISPLAY)")
    return lack


def work(*names):
    return os.path.join(WORKDIR, *names)


def capsflow(*args):
    return subprocess.run([BINARY, *args], cwd=WORKDIR, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          universal_newlines=True, env=dict(os.environ, OMP_NUM_THREADS="1"))


def probe(mp4):
    """(decoded frames, width, height, codec, frame rate) of the first video stream."""
    r = subprocess.run(["ffprobe", "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
                        "stream=nb_read_frames,width,height,codec_name,r_frame_rate", "-of", "json", mp4],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True, check=True)
    s = json.loads(r.stdout)["streams"][0]
    return int(s["nb_read_frames"]), s["width"], s["height"], s["codec_name"], s["r_frame_rate"]


def rgb(png):
    img = mpimg.imread(png)                     # floats in [0, 1], H x W x 3 or 4
    return img[:, :, :3]


def setUpModule():
    global WORKDIR
    if WORKDIR is None:
        WORKDIR = tempfile.mkdtemp(prefix="capsflow-render-")
        _made["tmp"] = WORKDIR
    os.makedirs(WORKDIR, exist_ok=True)
    with open(work("tiny.toml"), "w") as fh:
        fh.write(CONFIG)
    r = capsflow("run", "tiny.toml", "--threads", "1", "--force", "-q")
    if r.returncode != 0:
        raise AssertionError("capsflow run: %d\n%s" % (r.returncode, r.stderr))
    for d in ("pics", "stride", "view_side", "view_top", "view_oblique", "view_bad", "wrap"):
        shutil.rmtree(work(d), ignore_errors=True)


def tearDownModule():
    if "tmp" in _made:
        shutil.rmtree(_made["tmp"], ignore_errors=True)


class Render(unittest.TestCase):
    def test_1_last_frame_by_species(self):
        r = capsflow("render", "tiny.h5", "--out", "pics", "--size", "480x360")
        self.assertEqual(r.returncode, 0, r.stderr)
        png = work("pics", "tiny_species_f0004.png")
        self.assertIn("picture  pics/tiny_species_f0004.png (frame 4", r.stderr)
        img = rgb(png)
        self.assertEqual(img.shape, (360, 480, 3))
        r_, g_, b_ = img[:, :, 0], img[:, :, 1], img[:, :, 2]
        white = np.sum((r_ > 0.98) & (g_ > 0.98) & (b_ > 0.98))
        blue = np.sum((b_ > 0.3) & (b_ > r_ + 0.2) & (b_ > g_ + 0.05))         # tab:blue (0.12, 0.47, 0.71), shaded
        red = np.sum((r_ > 0.3) & (r_ > g_ + 0.25) & (r_ > b_ + 0.25))          # tab:red (0.84, 0.15, 0.16), shaded
        self.assertGreater(white, 0.4 * img.shape[0] * img.shape[1], "the background is white")
        self.assertGreater(blue, 300, "pixels of the stiff capsules' colour")
        self.assertGreater(red, 300, "pixels of the floppy capsules' colour")
        state = work("pics", "tiny_species.pvsm")
        root = ET.parse(state).getroot()
        self.assertEqual(root.tag, "GenericParaViewApplication")  # a ParaView state file (.pvsm)
        with open(state) as fh:
            self.assertIn(os.path.realpath(work("tiny.xdmf")), fh.read())
        self.assertEqual(sorted(os.listdir(work("pics"))), ["tiny_species.pvsm", "tiny_species_f0004.png"])

    def test_2_movie_by_tension(self):
        r = capsflow("render", "tiny.h5", "--out", "pics", "--color", "tension_max", "--movie", "--fps", "4",
                     "--size", "320x240", "--frame", "0")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("colour tension_max [mu gammadot a]", r.stderr)
        self.assertIn("encoding", r.stderr)
        self.assertEqual(probe(work("pics", "tiny_tension_max.mp4")), (FRAMES, 320, 240, "h264", "4/1"))
        img = rgb(work("pics", "tiny_tension_max_f0000.png"))
        self.assertEqual(img.shape, (240, 320, 3))
        spread = img.max(axis=2) - img.min(axis=2)
        self.assertGreater(np.sum(spread > 0.25), 200, "pixels of the colour map (not grey)")
        self.assertTrue(os.path.isfile(work("pics", "tiny_tension_max.pvsm")))

    def test_3_stride_and_no_silent_replacement(self):
        r = capsflow("render", "tiny.h5", "--out", "stride", "--movie", "--stride", "2", "--size", "320x240", "-q")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(r.stderr, "")
        self.assertEqual(probe(work("stride", "tiny_species.mp4"))[0], 3)
        before = {n: os.path.getmtime(work("stride", n)) for n in os.listdir(work("stride"))}
        again = capsflow("render", "tiny.h5", "--out", "stride", "--movie", "--stride", "2", "--size", "320x240")
        self.assertEqual(again.returncode, 2, again.stderr)
        self.assertTrue(again.stderr.startswith("capsflow: error: "), again.stderr)
        self.assertEqual(again.stderr.count("\n"), 1, again.stderr)
        self.assertIn("--force", again.stderr)
        self.assertEqual({n: os.path.getmtime(work("stride", n)) for n in os.listdir(work("stride"))}, before)

    def test_4_views_not_blank_and_different(self):
        imgs = {}
        for v in ("side", "top", "oblique"):
            r = capsflow("render", "tiny.h5", "--out", "view_" + v, "--view", v, "--size", "480x360", "-q")
            self.assertEqual(r.returncode, 0, r.stderr)
            img = rgb(work("view_" + v, "tiny_species_f0004.png"))
            r_, g_, b_ = img[:, :, 0], img[:, :, 1], img[:, :, 2]
            blue = np.sum((b_ > 0.3) & (b_ > r_ + 0.2) & (b_ > g_ + 0.05))
            red = np.sum((r_ > 0.3) & (r_ > g_ + 0.25) & (r_ > b_ + 0.25))
            dark = np.sum(img.max(axis=2) < 0.15)      # the box edges, the length bar, the labels
            self.assertGreater(blue, 150, "%s view: pixels of the stiff capsules' colour" % v)
            self.assertGreater(red, 150, "%s view: pixels of the floppy capsules' colour" % v)
            self.assertGreater(dark, 200, "%s view: the box, bar and labels drawn" % v)
            imgs[v] = img
            with open(work("view_" + v, "tiny_species.pvsm")) as fh:
                state = fh.read()
            # The title names the file, X_f and each species' Ca and count (the strain is added per frame).
            for part in ("tiny.h5", "X_f 0.5", "2 stiff (Ca 0.2)", "2 floppy (Ca 0.8)"):
                self.assertTrue(part in state, "%s view: the title lacks %r" % (v, part))  # not the whole state
        for a, b in (("side", "top"), ("side", "oblique"), ("top", "oblique")):
            diff = float(np.mean(np.abs(imgs[a] - imgs[b])))
            self.assertGreater(diff, 0.01, "the %s and %s views are the same picture (mean difference %g)" % (a, b, diff))
        r = capsflow("render", "tiny.h5", "--out", "view_bad", "--view", "front")
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("--view", r.stderr)
        self.assertFalse(os.path.exists(work("view_bad")))

    def test_5_capsules_across_the_periodic_boundary_inside_the_box(self):
        # A capsule across x = 0 and one across the corner x = Lx, z = Lz (issue 52, item 11): drawn cut at the box,
        # the part outside it on the other side. Before, they stuck out of the drawn box.
        with open(work("wrap.toml"), "w") as fh:
            fh.write(tiny_run.config(0.25, 0.05, 0.25, file="wrap.h5", species=["stiff", "floppy"],
                                     centres=[[0.3, 2.0, 3.0], [5.4, 4.0, 5.6]]))
        r = capsflow("run", "wrap.toml", "--threads", "1", "--force", "-q")
        self.assertEqual(r.returncode, 0, r.stderr)
        r = capsflow("render", "wrap.h5", "--out", "wrap", "--size", "640x480", "--frame", "0", "-q")
        self.assertEqual(r.returncode, 0, r.stderr)
        img = rgb(work("wrap", "wrap_species_f0000.png"))
        h, w = img.shape[:2]
        # The box's edges: the long dark lines (the side view: x to the right, y up).
        dark = img.max(axis=2) < 0.15
        cols = np.nonzero(dark.sum(axis=0) > 0.4 * h)[0]
        rows = np.nonzero(dark.sum(axis=1) > 0.3 * w)[0]
        self.assertTrue(len(cols) >= 2 and len(rows) >= 2, "the box's edges not found")
        left, right, top, bottom = cols.min(), cols.max(), rows.min(), rows.max()
        r_, g_, b_ = img[:, :, 0], img[:, :, 1], img[:, :, 2]
        blue = (b_ > 0.3) & (b_ > r_ + 0.2) & (b_ > g_ + 0.05)
        red = (r_ > 0.3) & (r_ > g_ + 0.25) & (r_ > b_ + 0.25)
        # The capsules' pixels level with the box, left of the colour bar (at 0.86 of the width).
        ys, xs = np.nonzero((blue | red)[top:bottom + 1, :int(0.84 * w)])
        self.assertGreater(len(xs), 300, "pixels of the capsules' colours")
        self.assertGreaterEqual(xs.min(), left - 2, "a capsule drawn left of the box")
        self.assertLessEqual(xs.max(), right + 2, "a capsule drawn right of the box")
        span = right - left
        self.assertTrue(np.any(xs < left + 0.1 * span) and np.any(xs > right - 0.1 * span),
                        "the pieces on both sides of the box")


def main(argv):
    global BINARY, WORKDIR
    required = os.environ.get("CAPSFLOW_REQUIRE_RENDER") == "1"
    lack = ([] if MISSING is None else ["numpy and matplotlib (%s)" % MISSING]) + missing_tools()
    if lack:
        msg = "the render tests need %s" % ", ".join(lack)
        if required:
            print("FAIL: %s (CAPSFLOW_REQUIRE_RENDER=1: tools/deps.sh installs them)" % msg, file=sys.stderr)
            return 1
        print("SKIP: %s (Debian: paraview python3-paraview xvfb xauth ffmpeg)" % msg)
        return SKIP
    if len(argv) >= 2:
        BINARY = os.path.abspath(argv[1])
    if len(argv) >= 3:
        WORKDIR = os.path.abspath(argv[2])
    if not os.access(BINARY, os.X_OK):
        print("capsflow executable not found: %s" % BINARY, file=sys.stderr)
        return 1
    prog = unittest.main(argv=[argv[0]], exit=False, verbosity=2)
    return 0 if prog.result.wasSuccessful() else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))

#!/usr/bin/env python3
"""OpenCV's multi-frame non-local means on a noisy EXR sequence: the peer of issue 11.

What a user without a real-time denoiser reaches for: cv2.fastNlMeansDenoisingColoredMulti
(Buades, Coll, Morel, CVPR 2005, with a temporal window). It works on 8-bit images, so each HDR
frame goes through the display transform `afterimage eval` scores in (Reinhard, then sRGB) to
8 bits, is denoised with its temporal neighbours, and comes back through the inverse transform
as a linear RGB EXR that `afterimage eval --out OUT --ref REF` scores like any other method.

    python3 tools/opencv_nlm.py --in NOISY --out OUT --h 6,12,20,30 --ref REFERENCE

With several --h values and --ref, every h is run, scored (mean display PSNR against the
reference) and the best one's frames are written; with one h no reference is needed. Prints the
time per frame. Needs Debian's python3-opencv (scripts/setup-deps.sh installs it).
The demo's denoising section runs the same OpenCV function through the C++ API
(src/peers/opencv_nlm.h); this script is the independent route through OpenCV's Python binding.
"""
import argparse
import glob
import os
import re
import sys
import time

os.environ.setdefault("OPENCV_IO_ENABLE_OPENEXR", "1")  # before cv2 is imported

try:
    import cv2
    import numpy as np
except ImportError as e:  # one line, non-zero exit
    sys.exit(f"opencv_nlm: {e}: install python3-opencv (Debian)")


def fail(msg):
    sys.exit(f"opencv_nlm: {msg}")


def frames_in(directory):
    """The EXR frames of a directory in frame order (name.0001.exr or name_0001.exr)."""
    if not os.path.isdir(directory):
        fail(f"'{directory}' is not a directory")
    files = [f for f in glob.glob(os.path.join(glob.escape(directory), "*.exr"))]
    numbered = []
    for f in files:
        m = re.search(r"[._](\d+)\.exr$", os.path.basename(f))
        if m:
            numbered.append((int(m.group(1)), f))
    if not numbered:
        fail(f"'{directory}' holds no numbered .exr frames")
    return [f for _, f in sorted(numbered)]


def read_rgb(path):
    """Linear RGB float32 (H, W, 3), channel order R, G, B."""
    img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if img is None or img.ndim != 3 or img.shape[2] < 3:
        fail(f"{path}: cannot read RGB channels")
    rgb = np.ascontiguousarray(img[:, :, 2::-1], dtype=np.float32)
    if not np.all(np.isfinite(rgb)):
        fail(f"{path}: NaN or Inf pixels")
    return rgb


def display(linear, exposure):
    """Reinhard then sRGB encoding, in [0, 1] (metrics/display.h)."""
    x = np.maximum(linear * exposure, 0.0)
    v = x / (1.0 + x)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1.0 / 2.4) - 0.055)


def linear_from_display(d, exposure):
    """The inverse of display(); code 255 maps to the radiance of code 254.5 (Reinhard's inverse
    has a pole at display 1)."""
    d = np.minimum(d, 254.5 / 255.0)
    v = np.where(d <= 0.04045, d / 12.92, np.power((d + 0.055) / 1.055, 2.4))
    return (v / (1.0 - v)) / exposure


def to_code(linear, exposure):
    # OpenCV's colour NLM expects BGR 8-bit.
    return np.clip(np.rint(display(linear, exposure) * 255.0), 0, 255).astype(np.uint8)[:, :, ::-1]


def from_code(code, exposure):
    return linear_from_display(code[:, :, ::-1].astype(np.float32) / 255.0, exposure).astype(
        np.float32
    )


def window_at(k, n, window):
    """The temporal window of frame k of n: `window`, shrunk (odd, centred) near the ends."""
    half = min((window - 1) // 2, k, n - 1 - k)
    return 2 * half + 1


def denoise(codes, h, args):
    out = []
    for k in range(len(codes)):
        win = window_at(k, len(codes), args.window)
        first = k - (win - 1) // 2
        res = cv2.fastNlMeansDenoisingColoredMulti(
            codes[first : first + win], (win - 1) // 2, win, None, h, h,
            args.template_size, args.search_size)
        out.append(res)
    return out


def psnr(a, b):
    mse = float(np.mean((a - b) ** 2))
    return float("inf") if mse == 0 else 10.0 * np.log10(1.0 / mse)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--in", dest="inp", required=True, help="noisy frames (EXR, linear RGB)")
    p.add_argument("--out", required=True, help="output directory: frame.NNNN.exr")
    p.add_argument("--h", default="10", help="filter strength(s), 8-bit units: H or H1,H2,...")
    p.add_argument("--ref", help="reference frames: with several --h, keep the best by PSNR")
    p.add_argument("--window", type=int, default=5, help="temporal window (odd)")
    p.add_argument("--template-size", type=int, default=7)
    p.add_argument("--search-size", type=int, default=21)
    p.add_argument("--exposure", type=float, default=1.0)
    a = p.parse_args()
    try:
        hs = [float(v) for v in a.h.split(",")]
    except ValueError:
        fail(f"--h '{a.h}': expected numbers separated by commas")
    if any(not (h > 0 and h < 1000) for h in hs):
        fail(f"--h '{a.h}': each h must be in (0, 1000)")
    if a.window < 1 or a.window % 2 == 0 or a.window > 31:
        fail(f"--window {a.window}: must be odd, 1..31")
    for name, v in (("--template-size", a.template_size), ("--search-size", a.search_size)):
        if v < 1 or v % 2 == 0 or v > 63:
            fail(f"{name} {v}: must be odd, 1..63")
    if not (a.exposure > 0 and np.isfinite(a.exposure)):
        fail(f"--exposure {a.exposure}: must be positive")
    if len(hs) > 1 and not a.ref:
        fail("several --h values need --ref to choose between them")

    inputs = frames_in(a.inp)
    refs = frames_in(a.ref) if a.ref else None
    if refs is not None and len(refs) < len(inputs):
        fail(f"--ref '{a.ref}' has {len(refs)} frames, --in has {len(inputs)}")
    # Never write over an input: the output directory must not be an input directory.
    out_real = os.path.realpath(a.out)
    for d in filter(None, (a.inp, a.ref)):
        if os.path.realpath(d) == out_real:
            fail(f"--out '{a.out}' is an input directory")

    noisy = [read_rgb(f) for f in inputs]
    shape = noisy[0].shape
    for f, img in zip(inputs, noisy):
        if img.shape != shape:
            fail(f"{f}: {img.shape[1]}x{img.shape[0]}, the first frame is {shape[1]}x{shape[0]}")
    codes = [to_code(img, a.exposure) for img in noisy]
    ref_display = [display(read_rgb(f), a.exposure) for f in refs[: len(inputs)]] if refs else None

    best = None
    for h in hs:
        t0 = time.perf_counter()
        den = denoise(codes, h, a)
        ms = 1e3 * (time.perf_counter() - t0) / len(codes)
        linear = [from_code(c, a.exposure) for c in den]
        line = f"h {h:g}: {ms:.1f} ms/frame"
        score = None
        if ref_display is not None:
            score = float(np.mean([psnr(display(x, a.exposure), r) for x, r in zip(linear, ref_display)]))
            line += f", display PSNR {score:.2f} dB"
        print(line, flush=True)
        if best is None or (score is not None and score > best[0]):
            best = (score, h, linear)

    os.makedirs(a.out, exist_ok=True)
    params = [cv2.IMWRITE_EXR_TYPE, cv2.IMWRITE_EXR_TYPE_FLOAT]
    for k, img in enumerate(best[2]):
        path = os.path.join(a.out, f"frame.{k:04d}.exr")
        if not cv2.imwrite(path, np.ascontiguousarray(img[:, :, ::-1]), params):
            fail(f"{path}: cannot write")
    print(f"wrote {len(best[2])} frames with h {best[1]:g} to {a.out}")


if __name__ == "__main__":
    main()

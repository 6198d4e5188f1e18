#!/usr/bin/env python3
"""Generates tests/data/ssim/: small deterministic image pairs and their SSIM according to
scikit-image, which tests/metrics_quality_test.cpp checks our SSIM against (within 1e-4).

    /usr/bin/python3 scripts/gen_ssim_testdata.py      # Debian's python3-skimage, numpy

SSIM settings are those of Wang et al. 2004 as scikit-image spells them:
    structural_similarity(a, b, gaussian_weights=True, sigma=1.5,
                          use_sample_covariance=False, data_range=1.0)
(11x11 Gaussian window from truncate=3.5; K1=0.01, K2=0.03; mean over pixels >= 5 px from
every border). RGB cases add channel_axis=-1 (mean of the per-channel SSIMs).

Images are stored as raw little-endian float32, row-major, channels interleaved (H, W, C),
and SSIM is computed on exactly those float32 values promoted to float64, so the C++ test
sees the same numbers. Output is deterministic (numpy PCG64 with fixed seeds).
"""
import json
import os
import sys

try:
    import numpy as np
    import skimage
    from skimage.metrics import structural_similarity
except ImportError as e:  # pyenv shims may hide Debian's packages
    sys.exit(f"{e}: run with /usr/bin/python3 (needs python3-numpy and python3-skimage)")

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "data", "ssim")


def smooth(h, w, c, rng):
    """A smooth field plus some texture, values roughly in [0, 1]."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    out = np.empty((h, w, c))
    for k in range(c):
        fx, fy, ph = rng.uniform(0.05, 0.4), rng.uniform(0.05, 0.4), rng.uniform(0, 6.3)
        out[..., k] = 0.5 + 0.3 * np.sin(fx * x + ph) * np.cos(fy * y) + 0.1 * rng.random((h, w))
    return out


def box_blur3(img):
    p = np.pad(img, ((1, 1), (1, 1), (0, 0)), mode="edge")
    h, w = img.shape[:2]
    return sum(p[dy:dy + h, dx:dx + w] for dy in range(3) for dx in range(3)) / 9.0


def make_cases():
    cases = []
    rng = np.random.default_rng(5151)
    # 1. Gray, additive Gaussian noise (odd size: borders and tails).
    a = smooth(29, 37, 1, rng)
    cases.append(("gray_noise", a, a + rng.normal(0.0, 0.05, a.shape)))
    # 2. Gray, 3x3 box blur of a noisy texture.
    a = rng.random((33, 41, 1))
    cases.append(("gray_blur", a, box_blur3(a)))
    # 3. RGB, one-pixel shift plus gain and offset.
    a = smooth(31, 45, 3, rng)
    b = np.roll(a, 1, axis=1) * 0.9 + 0.03
    cases.append(("rgb_shift_gain", a, b))
    # 4. RGB with values outside [0, 1] (HDR-like) and independent noise per channel.
    a = smooth(24, 26, 3, rng) * 1.7 - 0.2
    cases.append(("rgb_wide_range", a, a + rng.normal(0.0, 0.1, a.shape)))
    # 5. Flat images with an offset: only the luminance term (and C1, C2) matters.
    a = np.full((15, 13, 1), 0.5)
    cases.append(("gray_flat_offset", a, a + 0.1))
    # 6. The smallest image the window fits: the mean is one pixel.
    a = rng.random((11, 11, 1))
    cases.append(("gray_min_11x11", a, a * 0.8 + 0.1))
    # 7. Identical images: exactly 1.
    a = rng.random((20, 17, 3))
    cases.append(("rgb_identical", a, a.copy()))
    return cases


def main():
    os.makedirs(OUT, exist_ok=True)
    entries = []
    for name, a, b in make_cases():
        a32, b32 = a.astype(np.float32), b.astype(np.float32)
        h, w, c = a32.shape
        kw = dict(gaussian_weights=True, sigma=1.5, use_sample_covariance=False, data_range=1.0)
        a64, b64 = a32.astype(np.float64), b32.astype(np.float64)
        if c == 1:
            value = structural_similarity(a64[..., 0], b64[..., 0], **kw)
        else:
            value = structural_similarity(a64, b64, channel_axis=-1, **kw)
        for suffix, img in (("a", a32), ("b", b32)):
            with open(os.path.join(OUT, f"{name}_{suffix}.bin"), "wb") as f:
                f.write(img.astype("<f4").tobytes())
        entries.append({"name": name, "width": w, "height": h, "channels": c,
                        "a": f"{name}_a.bin", "b": f"{name}_b.bin", "ssim": float(value)})
        print(f"{name:18s} {w}x{h}x{c}  ssim = {value:.12f}")
    meta = {
        "generator": "scripts/gen_ssim_testdata.py",
        "skimage_version": skimage.__version__,
        "numpy_version": np.__version__,
        "call": "structural_similarity(a, b, gaussian_weights=True, sigma=1.5, "
                "use_sample_covariance=False, data_range=1.0[, channel_axis=-1])",
        "format": "raw little-endian float32, row-major, channels interleaved (H, W, C)",
        "cases": entries,
    }
    with open(os.path.join(OUT, "expected.json"), "w") as f:
        json.dump(meta, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()

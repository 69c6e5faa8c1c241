"""Benchmark: measuring full-size photographs versus merely decoding them.

Generates a capture of ``--images`` 980 x 980 16-bit RGB photographs (the
paper's size), as PNG and as uncompressed TIFF, then reports:

- PNG: ``cdbrdf.measure.measure`` over the folder (Dask local threads,
  checkpointed, output written) versus decoding every file whole with the
  library (:func:`imagecodecs.png_decode`, libpng) on the same number of
  threads. Target: measure time <= 1.15 x decode time. (A measurement
  decodes each PNG whole, checked, through libpng: the cost of reading is
  the library's.)
- TIFF (uncompressed): reading only the 7 x 7 patch
  (:func:`~cdbrdf.images.read_window`, memory-mapped with
  :func:`tifffile.memmap`) versus decoding the whole file with
  :func:`tifffile.imread`, one thread. Reported, no target: the former
  ">= 10 x" target was met by a hand-written TIFF directory parser (a few
  ``pread`` calls); with tifffile parsing the file's directory on every read,
  an uncompressed page is read whole (page cache) nearly as fast as the
  patch is mapped, and a measurement is decode-bound anyway.

Usage: ``python benchmarks/bench_measure.py [--images 300] [--keep DIR]``.
Exits 1 when the PNG target is missed.
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

SIZE = 980
PNG_TARGET = 1.15


def _generate(folder: Path, n: int, ext: str) -> None:
    from cdbrdf.colour import linear_to_srgb
    from cdbrdf.images import write_png, write_tiff

    rng = np.random.default_rng(0)
    y, x = np.mgrid[0:SIZE, 0:SIZE] / SIZE
    base = 0.15 + 0.3 * np.exp(-((x - 0.5) ** 2 + (y - 0.5) ** 2) / 0.1)
    base = np.stack([base, 0.8 * base, 0.5 * base], axis=-1)
    noise = rng.normal(0.0, 0.004, (SIZE + 64, SIZE + 64, 3))
    rows = []
    for i in range(n):
        s = 0.5 + i / (2 * n)
        o = i % 64
        lin = np.clip(base * s + noise[o : o + SIZE, o : o + SIZE], 0, 1)
        codes = np.round(linear_to_srgb(lin) * 65535).astype(np.uint16)
        name = f"img{i:04d}.{ext}"
        if ext == "png":
            write_png(folder / name, codes, level=1)
        else:
            write_tiff(folder / name, codes)
        # distinct conditions; every azimuth and curvature present from 36 images on
        rows.append(dict(file=name, kappa=[-0.2, 0.0, 0.2][(i // 12) % 3], theta_v=((i // 36) % 6) * 15,
                         phi_v=(i % 12) * 30, theta_l=((i // 216) % 6) * 15, phi_l=0))
    with open(folder / "capture.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def _library_decode(path: Path) -> np.ndarray:
    import imagecodecs

    return imagecodecs.png_decode(path.read_bytes())


def _decode_all(files: list[Path], workers: int) -> float:
    t = time.perf_counter()
    with ThreadPoolExecutor(workers) as ex:
        for a in ex.map(_library_decode, files):
            assert a.shape == (SIZE, SIZE, 3) and a.dtype == np.uint16
    return time.perf_counter() - t


def _measure(folder: Path, out: Path, workers: int) -> float:
    from cdbrdf.measure import measure

    if out.exists():
        out.unlink()
    t = time.perf_counter()
    table, rep = measure(folder, out, num_workers=workers, batch_size=4 * workers)
    dt = time.perf_counter() - t
    assert rep.n_images == len(list(folder.glob("img*")))
    return dt


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--images", type=int, default=300, help="photographs per format (300)")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="threads (all cores)")
    ap.add_argument("--repeat", type=int, default=2, help="timing repetitions, best kept (2)")
    ap.add_argument("--keep", default=None, help="generate into this folder and keep it")
    args = ap.parse_args(argv)

    root = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="bench_measure_"))
    results = []
    ok = True
    try:
        for ext in ("png", "tif"):
            folder = root / ext
            folder.mkdir(parents=True, exist_ok=True)
            t = time.perf_counter()
            if not (folder / "capture.csv").exists():
                _generate(folder, args.images, ext)
            gen = time.perf_counter() - t
            files = sorted(folder.glob(f"img*.{ext}"))
            size_mb = sum(f.stat().st_size for f in files) / len(files) / 2**20
            import tifffile

            from cdbrdf.images import read_image, read_window
            from cdbrdf.measure.patch import patch_window

            read_image(files[0])  # import the readers outside the timings
            if ext == "png":
                dec = min(_decode_all(files, args.workers) for _ in range(args.repeat))
                mea = min(_measure(folder, root / "png.h5", args.workers) for _ in range(args.repeat))
                ratio = mea / dec
                passed = ratio <= PNG_TARGET
                results.append(("PNG 16-bit", len(files), size_mb, gen, dec, mea, len(files) / mea,
                                f"measure/decode = {ratio:.3f} (target <= {PNG_TARGET})", passed))
            else:
                win = lambda info: patch_window(info, n=7)  # noqa: E731
                full = patch = np.inf
                for _ in range(args.repeat):
                    t = time.perf_counter()
                    for f in files:
                        tifffile.imread(f)
                    full = min(full, time.perf_counter() - t)
                    t = time.perf_counter()
                    for f in files:
                        read_window(f, win)
                    patch = min(patch, time.perf_counter() - t)
                mea = min(_measure(folder, root / "tif.h5", args.workers) for _ in range(args.repeat))
                speed = full / patch
                passed = True  # reported only
                results.append(("TIFF 16-bit raw", len(files), size_mb, gen, full, mea, len(files) / mea,
                                f"full decode/patch read = {speed:.1f}x (no target); "
                                f"patch read {1e3 * patch / len(files):.2f} ms/img", passed))
            ok &= passed
    finally:
        if not args.keep:
            import shutil

            shutil.rmtree(root, ignore_errors=True)

    print(f"bench_measure: {args.images} photographs of {SIZE} x {SIZE} x 3 x 16 bit per format, "
          f"{args.workers} worker thread(s), best of {args.repeat}")
    print(f"{'format':<16} {'n':>4} {'MB/img':>7} {'decode s':>9} {'measure s':>10} {'img/s':>7}  result")
    for name, n, mb, _gen, dec, mea, ips, text, passed in results:
        print(f"{name:<16} {n:>4} {mb:>7.2f} {dec:>9.2f} {mea:>10.2f} {ips:>7.1f}  "
              f"{text} {'PASS' if passed else 'FAIL'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

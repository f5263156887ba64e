"""Benchmark: 10 MHz filter + H1 of a 1e8-sample, 4-channel recording with bounded memory.

Writes a float32 (4, n) recording (three PWM-like inputs, one output = known filter of the
inputs + noise) to a temporary memmap file in chunks, then streams it block by block
through vfmodel.signals.filters.filter_blocks and h1_analysis_blocks, and prints the peak
resident memory of the process (resource.getrusage, includes the file pages mapped while
a block is read) and the accuracy of H against the known filter. The file is deleted.

    .venv/bin/python scripts/bench_memory_h1.py [--n 100000000] [--block 1048576]
"""

from __future__ import annotations

import argparse
import resource
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import scipy.signal as ss

from vfmodel.signals.filters import filter_blocks
from vfmodel.signals.h1 import h1_analysis_blocks

FS = 100e6
SYSTEMS = [([0.02, 0.01], [1, -1.6, 0.81]), ([0.015], [1, -0.9]), ([0.04, 0.005], [1, -1.2, 0.5])]


def write_recording(path: Path, n: int, chunk: int) -> None:
    """Write a (4, n) float32 .npy file chunk by chunk with plain seeks and writes (no
    memory map, so the written pages never count in this process's resident memory)."""
    rng = np.random.default_rng(0)
    zi = [np.zeros(len(a) - 1) for _, a in SYSTEMS]
    with open(path, "wb") as fh:
        np.lib.format.write_array_header_1_0(
            fh, {"descr": "<f4", "fortran_order": False, "shape": (4, n)}
        )
        data0 = fh.tell()
        for s in range(0, n, chunk):
            m = min(chunk, n - s)
            x = 130 * (rng.uniform(size=(3, m)) < 0.5) + rng.normal(0, 0.5, (3, m))
            y = np.zeros(m)
            for k, (b, a) in enumerate(SYSTEMS):
                yk, zi[k] = ss.lfilter(b, a, x[k], zi=zi[k])
                y += yk
            y += rng.normal(0, np.std(y), m)  # SNR ~ 0 dB
            for ch, row in enumerate((*x, y)):
                fh.seek(data0 + 4 * (ch * n + s))
                fh.write(np.asarray(row, dtype="<f4").tobytes())


def read_blocks(path: Path, block: int) -> Iterator[np.ndarray]:
    """Map the file anew for every block so only one block's pages stay resident."""
    n = np.load(path, mmap_mode="r").shape[1]
    for s in range(0, n, block):
        mm = np.load(path, mmap_mode="r")
        out = np.array(mm[:, s : s + block], dtype=np.float64)
        del mm
        yield out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100_000_000)
    ap.add_argument("--block", type=int, default=2**20)
    ap.add_argument("--nperseg", type=int, default=8192)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="vfmodel-bench-") as tmp:
        path = Path(tmp) / "rec.npy"
        t0 = time.perf_counter()
        write_recording(path, args.n, args.block)
        t1 = time.perf_counter()
        print(f"wrote {path.stat().st_size / 1e9:.2f} GB ({args.n} samples x 4 float32) "
              f"in {t1 - t0:.1f} s")
        rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        filt = filter_blocks(read_blocks(path, args.block), FS, 10e6)
        res = h1_analysis_blocks(filt, FS, n_in=3, nperseg=args.nperseg)
        t2 = time.perf_counter()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # kB -> MB (Linux)
    ref = np.stack([ss.freqz(b, a, worN=res.freq_hz, fs=FS)[1] for b, a in SYSTEMS], axis=1)
    ok = res.coherence[:, 0] > 0.9
    err = np.abs(np.abs(res.h[ok, 0]) / np.abs(ref[ok]) - 1)
    z = np.abs(res.h[res.valid, 0] - ref[res.valid]) / res.h_std[res.valid, 0]
    print(f"filter + H1 of {args.n} samples in {t2 - t1:.1f} s, {res.n_averages} averages")
    print(f"peak RSS {peak:.0f} MB (after writing the file: {rss_before:.0f} MB)")
    print(f"max | |H1|/|H| - 1 | where coherence > 0.9 ({int(ok.sum())} bins): "
          f"{(err.max() if err.size else np.nan) * 100:.3f} %; "
          f"median |H1 - H| / h_std: {np.median(z):.2f}")


if __name__ == "__main__":
    main()

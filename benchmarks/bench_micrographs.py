"""Time and peak memory of the micrograph pipeline as the stack grows towards the paper's (1280 x 960 px RGB, 72
sections of 5 um).

Each size runs in its own process (peak resident memory is per process): a synthetic phantom block of 72 sections is
rendered once at ``--tile`` px (in a process of its own, saved to a temporary file), and the rendered (already
misregistered) sections are tiled side by side up to the size asked, so that the registration, segmentation, point
counting and tracing see images of that size; each tile has an 8 px blank border, so that cells do not continue
from one copy into the next. The tiled stack repeats one phantom's content: a speed and memory benchmark, not a
validation.

    python benchmarks/bench_micrographs.py                      # 240x320, 480x640, 960x1280 px, 72 sections
    python benchmarks/bench_micrographs.py --sizes 240x320 --sections 18

Prints per size: pixels, the stack's own size in memory (uint8), wall time per stage, the peak resident memory of
the process (``resource.getrusage``) and how much of it the pipeline added over the loaded stack.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def _render(path: str, sections: int, tile: tuple[int, int], seed: int) -> None:
    """Render the phantom's sections (``tile`` px) and save them: the pipeline's processes do not pay for it."""
    import numpy as np

    from bayestissue.stereology.micrographs.phantom import PhantomOptions, make_phantom
    from bayestissue.stereology.micrographs.render import render_sections

    th, tw = tile
    phantom = make_phantom(PhantomOptions(extent_um=(5.0 * sections, th + 40.0, tw + 40.0)), rng=seed)
    stack = render_sections(phantom, thickness_um=5.0, axis="z", rng=seed)
    np.save(path, np.ascontiguousarray(stack.images[:, :th, :tw]))


def _one(path: str, height: int, width: int, seed: int) -> dict:
    """Tile the saved sections to ``height x width`` and run the pipeline; peak RSS of this process."""
    import numpy as np

    from bayestissue.stereology.micrographs.pipeline import analyse_micrographs

    base = np.load(path)
    # a blank (cavity-white) border on each tile: cells cut at a tile's edge do not continue into the next copy
    # (tiled edge to edge, they chained across the whole image into a few huge traced regions)
    gap = 8
    base[:, :gap], base[:, -gap:], base[:, :, :gap], base[:, :, -gap:] = 255, 255, 255, 255
    reps = (1, -(-height // base.shape[1]), -(-width // base.shape[2]), 1)
    images = np.ascontiguousarray(np.tile(base, reps)[:, :height, :width])
    del base
    rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    stages, last = {}, [time.perf_counter(), None]

    def stage(name):
        now = time.perf_counter()
        if last[1] is not None:
            stages[last[1]] = now - last[0]
        last[:] = [now, name]

    t1 = time.perf_counter()
    res = analyse_micrographs(images, pixel_um=1.0, thickness_um=5.0, grid_spacing_um=10.0, rng=seed, stage=stage)
    stage(None)
    return {
        "size": f"{height}x{width}",
        "sections": int(images.shape[0]),
        "megapixels": images.shape[0] * height * width / 1e6,
        "stack_mb": images.nbytes / 2**20,
        "pipeline_s": time.perf_counter() - t1,
        "stages_s": stages,
        "rss_before_mb": rss_before,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "cells_traced": int(len(np.unique(res.traced.cell_id))),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", default=["240x320", "480x640", "960x1280"], help="HxW in px")
    ap.add_argument("--sections", type=int, default=72)
    ap.add_argument("--tile", default="240x320", help="HxW of the rendered phantom sections that are tiled")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--render", help=argparse.SUPPRESS)  # a child process: render the tile stack into this file
    ap.add_argument("--one", help=argparse.SUPPRESS)  # a child process: one size, JSON on stdout
    args = ap.parse_args(argv)
    tile = tuple(int(x) for x in args.tile.split("x"))
    if args.render:
        _render(args.render, args.sections, tile, args.seed)
        return 0
    if args.one:
        path, size = args.one.split("@")
        h, w = (int(x) for x in size.split("x"))
        print(json.dumps(_one(path, h, w, args.seed)))
        return 0
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        stack = os.path.join(tmp, "sections.npy")
        common = ["--sections", str(args.sections), "--tile", args.tile, "--seed", str(args.seed)]
        subprocess.run([sys.executable, __file__, "--render", stack, *common], check=True)
        for size in args.sizes:
            out = subprocess.run(
                [sys.executable, __file__, "--one", f"{stack}@{size}", *common], capture_output=True, text=True
            )
            if out.returncode != 0:
                print(f"{size}: failed\n{out.stderr[-2000:]}")
                continue
            r = json.loads(out.stdout.strip().splitlines()[-1])
            rows.append(r)
            st = ", ".join(f"{k} {v:.1f}" for k, v in r["stages_s"].items())
            grown = r["peak_rss_mb"] - r["rss_before_mb"]
            print(
                f"{r['size']} px x {r['sections']} sections ({r['megapixels']:.0f} Mpx, stack {r['stack_mb']:.0f} MB "
                f"uint8): pipeline {r['pipeline_s']:.1f} s ({st}); peak RSS {r['peak_rss_mb']:.0f} MB, of which "
                f"{grown:.0f} MB during the pipeline = {grown / r['stack_mb']:.1f} x the stack; "
                f"{r['cells_traced']} cells traced",
                flush=True,
            )
    if len(rows) >= 2:
        a, b = rows[0], rows[-1]
        print(
            f"from {a['size']} to {b['size']}: pixels x {b['megapixels'] / a['megapixels']:.1f}, time x "
            f"{b['pipeline_s'] / a['pipeline_s']:.1f}, peak memory x {b['peak_rss_mb'] / a['peak_rss_mb']:.1f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

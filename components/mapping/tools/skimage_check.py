#!/usr/bin/env python3
"""Compares speleo-mapping's marching cubes with scikit-image's on the same
TSDF grid (written by `examples/dense_dump.rs`).

    cargo run --release -p speleo-mapping --example dense_dump -- /tmp/mc sphere
    python3 components/mapping/tools/skimage_check.py /tmp/mc

A cube takes part when its eight voxels were observed (weight > 0):
scikit-image's `mask` marks the cubes by their last corner (found by
experiment with version 0.26). Exits non-zero
when the vertex counts differ by more than 1 %.
"""
import json
import sys
from pathlib import Path

import numpy as np
from skimage.measure import marching_cubes

d = Path(sys.argv[1])
meta = json.loads((d / "grid.json").read_text())
dims = tuple(meta["dims"])
raw = np.fromfile(d / "grid.f32", dtype="<f4")
n = int(np.prod(dims))
tsdf = raw[:n].reshape(dims).astype(np.float64)
weight = raw[n:].reshape(dims)
obs = weight > 0
cube = np.zeros(dims, dtype=bool)
c = obs[:-1, :-1, :-1].copy()
for dx in (0, 1):
    for dy in (0, 1):
        for dz in (0, 1):
            c &= obs[dx:dims[0] - 1 + dx, dy:dims[1] - 1 + dy, dz:dims[2] - 1 + dz]
# scikit-image reads the mask at a cube's last corner (its loops run over
# the far index), so shift the cube mask by one voxel.
cube[1:, 1:, 1:] = c
# Unobserved voxels take no part (masked); give them a value all the same.
tsdf[~obs] = meta["truncation"]
for method in ("lewiner", "lorensen"):
    verts, faces, _, _ = marching_cubes(tsdf, level=0.0, mask=cube, method=method,
                                        allow_degenerate=True)
    ours = meta["vertices"]
    diff = (ours - len(verts)) / len(verts)
    print(f"{method}: scikit-image {len(verts)} vertices, {len(faces)} triangles; "
          f"speleo-mapping {ours} vertices, {meta['triangles']} triangles "
          f"({100 * diff:+.3f} % vertices)")
    if abs(diff) > 0.01:
        sys.exit(1)

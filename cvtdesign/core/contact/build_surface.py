"""Build the creep-force table (core.contact.surface) from FASTSIM.

    python -m cvtdesign.core.contact.build_surface [--out PATH]

evaluates FASTSIM with the Hertz traction bound (core.contact.fastsim, nx = 200, ny = 100, extrapolated) at
every node of the table: surface.RATIO_NODES × the ξ̂ ≥ 0, η̂ ≥ 0 part of the z grid (21 × 21 × 41 nodes a
ratio), and writes the values (float32) with the grid's definition. About 5 minutes on one core. The shipped
table was made this way; tests/validation/test_surface.py recomputes some of its nodes.
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from cvtdesign.core.contact import fastsim, surface


def quarter_nodes() -> np.ndarray:
    """The z nodes of the stored part, shape (3, h, h, n): ξ̂ ≥ 0 and η̂ ≥ 0, every φ̂."""
    g = surface.grid()
    half = g[g >= -1e-12]
    return np.stack(np.meshgrid(half, half, g, indexing="ij"))


def table(progress=None) -> np.ndarray:
    """FASTSIM at every stored node: (ratio, output, h, h, n) float32."""
    z = quarter_nodes()
    c = surface.expand(z.reshape(3, -1))
    out = []
    for k, ratio in enumerate(surface.RATIO_NODES):
        out.append(np.stack(fastsim.fastsim(*c, ratio)).reshape((3,) + z.shape[1:]))
        if progress:
            progress(k + 1, len(surface.RATIO_NODES))
    return np.stack(out).astype(np.float32)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(surface.DATA))
    args = parser.parse_args(argv)
    start = time.perf_counter()
    values = table(lambda k, n: print(f"a/b node {k}/{n}, {time.perf_counter() - start:.0f} s", file=sys.stderr))
    np.savez_compressed(args.out, values=values, ratio_nodes=surface.RATIO_NODES, rho_scale=surface.RHO_SCALE, mapping=surface.MAPPING,
                        grid_points=surface.GRID_POINTS, fastsim=np.array([fastsim.NX, fastsim.NY]))
    print(f"{args.out}: {values.shape} in {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

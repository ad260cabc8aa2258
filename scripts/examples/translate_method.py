#!/usr/bin/env python3
"""An external deformation-transfer method for deformlab (kind = "external").

The simplest method that uses the key point pairs: every deformed target
B'_j is the target B translated by the mean displacement of the source's
key points from A to A'_j. Standard library only, so it runs wherever
python3 does. The harness calls it once per case, as the config's
`command` says (experiments/examples/own-method.toml):

    python3 scripts/examples/translate_method.py --source {source} \
        --target {target} --markers {markers} --out {out} {poses}

Inputs are OBJ files (A, the poses A'_1..A'_m, B) and a CSV of key point
pairs `source,target` (vertex indices, 0-based). It must write
OUT/result_<j>.obj (j = 1..m) with B's vertices in B's order; faces are
optional (B's are used). A non-zero exit, a missing result or a wrong
vertex count fails that case only; anything printed to standard error is
kept in the failure's message.
"""

import argparse
import csv
import os
import sys


def read_obj_vertices(path):
    """The `v x y z` lines of an OBJ file."""
    vertices = []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                x, y, z = map(float, line.split()[1:4])
                vertices.append((x, y, z))
    return vertices


def write_obj_vertices(path, vertices):
    with open(path, "w") as f:
        for x, y, z in vertices:
            f.write(f"v {x!r} {y!r} {z!r}\n")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--source", required=True)
    p.add_argument("--target", required=True)
    p.add_argument("--markers", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("poses", nargs="+")
    a = p.parse_args(argv)
    A = read_obj_vertices(a.source)
    B = read_obj_vertices(a.target)
    with open(a.markers, newline="") as f:
        sources = [int(r["source"]) for r in csv.DictReader(f)]
    if not sources:
        sys.exit("no key point pairs in " + a.markers)
    for j, pose in enumerate(a.poses, start=1):
        P = read_obj_vertices(pose)
        if len(P) != len(A):
            sys.exit(f"{pose}: {len(P)} vertices, the source has {len(A)}")
        shift = [sum(P[s][k] - A[s][k] for s in sources) / len(sources) for k in range(3)]
        moved = [(x + shift[0], y + shift[1], z + shift[2]) for x, y, z in B]
        write_obj_vertices(os.path.join(a.out, f"result_{j}.obj"), moved)
        print(f"pose {j}: shift {shift}", file=sys.stderr)


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""The best global scale alpha the FBT energy can give, computed at the true answer.

An independent check (numpy / scipy / trimesh only, none of deformlab's code)
of how close FBT's scale estimator (paper 001, Eq. 16: alpha = sum_k tr(R_k
S_k) / sum w |e|^2 with one rotation R_k per rotation cluster) can get to an
applied scale s. The deformed shape is set to the exact answer (the target
scaled by s about its centroid); the rotations are then the optimal ones for
that shape, so no solver can reach a better fit of the energy, and the alpha
it assigns is the estimator's own value there. Two clusterings:

- r clusters by k-means of the first m cotangent-Laplacian eigenfunctions of
  the reference (the kind of clustering FBT's LBO pipelines use; r = 20,
  m = 10 by default; scipy's k-means, seeded);
- one rotation per vertex (its 1-ring, classic ARAP): the finest clustering,
  the largest alpha any clustering can give.

For each example (the reference and the others given) the script prints
alpha / s for both, and for the example E_mn would pick (the lowest energy
at the optimal alpha).

    python3 scripts/alpha_oracle.py --scale 1.5 REF.ply TARGET.ply [EXAMPLE.ply ...]

All meshes must share one vertex order and face list (one class).
"""

import argparse
import sys

import numpy as np


def load(path):
    import trimesh

    m = trimesh.load(path, process=False)
    return np.asarray(m.vertices, dtype=float), np.asarray(m.faces, dtype=np.int64)


def cotan_edges(v, f):
    """Half-edge list (i, j, w) with cotangent weights w_ij = (cot a + cot b) / 2."""
    rows, cols, ws = [], [], []
    for k in range(3):
        i, j, o = f[:, k], f[:, (k + 1) % 3], f[:, (k + 2) % 3]
        a, b = v[i] - v[o], v[j] - v[o]
        cross = np.linalg.norm(np.cross(a, b), axis=1)
        cot = np.einsum("ij,ij->i", a, b) / np.maximum(cross, 1e-300)
        rows += [i, j]
        cols += [j, i]
        ws += [0.5 * cot, 0.5 * cot]
    import scipy.sparse as sp

    n = len(v)
    w = sp.coo_matrix((np.concatenate(ws), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)).tocsr()
    w.sum_duplicates()
    return w


def lbo_clusters(v, f, m, r, seed):
    import scipy.sparse as sp
    import scipy.sparse.linalg as sla
    from scipy.cluster.vq import kmeans2

    w = cotan_edges(v, f)
    lap = sp.diags(np.asarray(w.sum(axis=1)).ravel()) - w
    # Lumped (barycentric) mass.
    area = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    mass = np.zeros(len(v))
    for k in range(3):
        np.add.at(mass, f[:, k], area / 3.0)
    vals, vecs = sla.eigsh(lap, k=m, M=sp.diags(mass), sigma=-1e-8, which="LM")
    order = np.argsort(vals)
    feats = vecs[:, order]
    rng = np.random.default_rng(seed)
    _, labels = kmeans2(feats, r, seed=rng, minit="++")
    return labels, w


def best_rotation_trace(s):
    """max over rotations R of tr(R S), S 3x3 (batched: (..., 3, 3))."""
    u, sig, vt = np.linalg.svd(s)
    d = np.sign(np.linalg.det(u @ vt))
    sig = sig.copy()
    sig[..., 2] *= d
    return sig.sum(axis=-1)


def oracle_alpha(w, labels, p, e):
    """sum_k max_R tr(R S_k) / sum w |e|^2 with S_k = sum_{i in k, j} w_ij e_ij p_ij^T."""
    w = w.tocoo()
    i, j, c = w.row, w.col, w.data
    pe = p[j] - p[i]
    ee = e[j] - e[i]
    outer = c[:, None, None] * ee[:, :, None] * pe[:, None, :]
    k = labels[i]
    nk = labels.max() + 1
    s = np.zeros((nk, 3, 3))
    np.add.at(s, k, outer)
    denom = np.sum(c * np.einsum("ij,ij->i", ee, ee))
    tr = best_rotation_trace(s).sum()
    energy_best = np.sum(c * np.einsum("ij,ij->i", pe, pe)) - tr**2 / denom
    return tr / denom, energy_best


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scale", type=float, default=1.5)
    ap.add_argument("--clusters", type=int, default=20)
    ap.add_argument("--m", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("reference")
    ap.add_argument("target")
    ap.add_argument("examples", nargs="*")
    a = ap.parse_args(argv)
    vref, f = load(a.reference)
    vt, ft = load(a.target)
    if vt.shape != vref.shape or not np.array_equal(np.sort(ft, axis=1), np.sort(f, axis=1)):
        sys.exit(f"{a.target}: not the reference's vertex order and face list")
    exs = [(a.reference, vref)]
    for path in a.examples:
        ve, fe = load(path)
        if ve.shape != vref.shape:
            sys.exit(f"{path}: {len(ve)} vertices, the reference has {len(vref)}")
        exs.append((path, ve))
    c = vt.mean(axis=0)
    p = c + a.scale * (vt - c)
    labels, w = lbo_clusters(vref, f, a.m, a.clusters, a.seed)
    per_vertex = np.arange(len(vref))
    best = None
    for path, ve in exs:
        # The energy against example l uses l's own cotangent weights.
        wl = w if ve is vref else cotan_edges(ve, f)
        ac, ec = oracle_alpha(wl, labels, p, ve)
        av, _ = oracle_alpha(wl, per_vertex, p, ve)
        print(f"{path}: alpha/s clusters {ac / a.scale:.4f}  per vertex {av / a.scale:.4f}")
        if best is None or ec < best[0]:
            best = (ec, path, ac, av)
    _, path, ac, av = best
    print(f"E_mn's example {path}: alpha/s clusters {ac / a.scale:.4f}  per vertex {av / a.scale:.4f}")


if __name__ == "__main__":
    main()

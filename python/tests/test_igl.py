"""Cross-check of cotmatrix / massmatrix against libigl's Python package.

Skipped (with the reason) when `igl` does not import. Our Laplacian is the
positive semi-definite one: cotmatrix == -igl.cotmatrix. Both mass matrices
are the mixed Voronoi areas of Meyer et al.
"""

import numpy as np
import pytest

import deformlab as dl

igl = pytest.importorskip("igl", reason="SKIP: libigl's python package (pip install libigl) is not installed")


def _igl_version():
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("libigl")
    except PackageNotFoundError:
        return "?"


def _compare(V, F, label):
    L = dl.cotmatrix(V, F)
    Li = igl.cotmatrix(V, F)
    M = dl.massmatrix(V, F)
    Mi = igl.massmatrix(V, F, igl.MASSMATRIX_TYPE_VORONOI)
    dL = abs(L + Li).max()
    dM = abs(M - Mi).max()
    scaleL = abs(Li).max()
    scaleM = abs(Mi).max()
    print(f"\nlibigl {_igl_version()} cross-check on {label} ({len(V)} v): "
          f"max|L + L_igl| = {dL:.3e} (max|L| {scaleL:.3e}), max|M - M_igl| = {dM:.3e} (max M {scaleM:.3e})")
    assert dL <= 1e-10 * scaleL
    assert dM <= 1e-10 * scaleM


def test_synthetic_against_igl(small_set):
    _compare(small_set["V"][0][0], small_set["F"], "synthetic subject 0")


def test_sphere_against_igl(sphere):
    _compare(*sphere, "UV sphere")


def test_faust_against_igl(faust_dir):
    V, F = dl.read_mesh(sorted(faust_dir.glob("*.ply"))[0])
    _compare(V, F, "FAUST")

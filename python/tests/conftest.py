"""Shared fixtures: the repository, the CLI binary, the data root, small meshes."""

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import deformlab as dl

REPO = Path(__file__).resolve().parents[2]


def cli_path():
    """The `deformlab` binary: DEFORMLAB_CLI, else the repository's release build."""
    p = os.environ.get("DEFORMLAB_CLI") or str(REPO / "target" / "release" / "deformlab")
    return p if os.path.isfile(p) and os.access(p, os.X_OK) else None


def data_root():
    """DEFORMLAB_DATA (or the former DEFORMLAB_SHARED_DATA), else ../shared/data beside the checkout."""
    for var in ("DEFORMLAB_DATA", "DEFORMLAB_SHARED_DATA"):
        if os.environ.get(var):
            p = Path(os.environ[var])
            return p if p.is_dir() else None
    p = REPO.parent / "shared" / "data"
    return p if p.is_dir() else None


@pytest.fixture(scope="session")
def cli():
    p = cli_path()
    if p is None:
        pytest.skip(
            "SKIP: no deformlab CLI binary (build it with `cargo build --release`, or set DEFORMLAB_CLI)"
        )
    return p


@pytest.fixture(scope="session")
def faust_dir():
    root = data_root()
    if root is None or not (root / "faust").is_dir():
        pytest.skip("SKIP: no real data (set DEFORMLAB_DATA, or put the data in ../shared/data)")
    return root / "faust"


@pytest.fixture(scope="session")
def small_set():
    """Synthetic set, 2 subjects × 3 poses at resolution 1 (1682 vertices)."""
    return dl.synthetic(subjects=2, poses=3, resolution=1)


@pytest.fixture(scope="session")
def mesh(small_set):
    return small_set["V"][0][0], small_set["F"]


@pytest.fixture(scope="session")
def synthetic_files(tmp_path_factory, small_set):
    """The small synthetic set written as PLY files (subject s, pose p → s{s}p{p}.ply)."""
    d = tmp_path_factory.mktemp("synthetic")
    for s, poses in enumerate(small_set["V"]):
        for p, V in enumerate(poses):
            dl.write_mesh(d / f"s{s}p{p}.ply", V, small_set["F"])
    yield d
    shutil.rmtree(d, ignore_errors=True)


def unit_sphere(n_lat=24, n_lon=48):
    """A closed UV sphere of radius 1 (poles at ±z)."""
    V = [[0.0, 0.0, 1.0]]
    for i in range(1, n_lat):
        th = np.pi * i / n_lat
        for j in range(n_lon):
            ph = 2 * np.pi * j / n_lon
            V.append([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
    V.append([0.0, 0.0, -1.0])
    F = []
    ring = lambda i, j: 1 + i * n_lon + (j % n_lon)  # noqa: E731
    for j in range(n_lon):
        F.append([0, ring(0, j), ring(0, j + 1)])
    for i in range(n_lat - 2):
        for j in range(n_lon):
            F.append([ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)])
            F.append([ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)])
    s = len(V) - 1
    for j in range(n_lon):
        F.append([s, ring(n_lat - 2, j + 1), ring(n_lat - 2, j)])
    return np.array(V), np.array(F, dtype=np.int64)


@pytest.fixture(scope="session")
def sphere():
    return unit_sphere()

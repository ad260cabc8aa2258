"""Shapes, dtypes and analytic properties of the operators and methods."""

import numpy as np
import pytest
import scipy.sparse as sp

import deformlab as dl


def test_version_is_the_crates():
    from conftest import REPO

    text = (REPO / "Cargo.toml").read_text()
    line = next(l for l in text.splitlines() if l.startswith("version"))
    assert dl.__version__ == line.split('"')[1]


def test_read_write_roundtrip(tmp_path, mesh):
    V, F = mesh
    for ext in ("ply", "obj", "off"):
        p = tmp_path / f"m.{ext}"
        dl.write_mesh(p, V, F)
        V2, F2 = dl.read_mesh(p)
        assert V2.dtype == np.float64 and V2.shape == V.shape
        assert F2.dtype == np.int64 and F2.shape == F.shape
        np.testing.assert_array_equal(F2, F)
        # PLY is binary double: exact; OBJ/OFF are text.
        tol = 0 if ext == "ply" else 1e-9
        assert np.abs(V2 - V).max() <= tol


def test_inspect_reports_defects(mesh):
    V, F = mesh
    r = dl.inspect(V, F)
    assert r["clean"] and r["n_vertices"] == len(V) and r["n_faces"] == len(F)
    assert r["genus"] == 0 and len(r["components"]) == 1
    # A duplicated face and a NaN vertex are reported, not refused.
    V2 = V.copy()
    V2[5] = np.nan
    r = dl.inspect(V2, np.vstack([F, F[:1]]))
    assert r["duplicate_faces"]["count"] == 1
    assert r["non_finite_vertices"] == {"count": 1, "first": [5]}
    assert not r["clean"] and not r["loadable"]


def test_cotmatrix_and_massmatrix_on_the_sphere(sphere):
    V, F = sphere
    L = dl.cotmatrix(V, F)
    M = dl.massmatrix(V, F)
    assert isinstance(L, sp.csr_matrix) and L.shape == (len(V), len(V)) and L.dtype == np.float64
    assert abs(L - L.T).max() < 1e-12
    assert np.abs(L @ np.ones(len(V))).max() < 1e-12  # constants in the kernel
    m = M.diagonal()
    assert (m > 0).all()
    # Area of the inscribed polyhedron: a little below 4π.
    assert 0.98 * 4 * np.pi < m.sum() < 4 * np.pi
    mb = dl.massmatrix(V, F, kind="barycentric").diagonal()
    assert abs(mb.sum() - m.sum()) < 1e-10


def test_lbo_eigenpairs_sphere_spectrum(sphere):
    V, F = sphere
    lam, Phi = dl.lbo_eigenpairs(V, F, 9)
    assert lam.shape == (9,) and Phi.shape == (len(V), 9)
    # Unit sphere: 0, 2 (×3), 6 (×5).
    np.testing.assert_allclose(lam, [0, 2, 2, 2, 6, 6, 6, 6, 6], atol=0.1)
    M = dl.massmatrix(V, F)
    np.testing.assert_allclose(Phi.T @ (M @ Phi), np.eye(9), atol=1e-8)


def test_heat_geodesic_on_the_sphere(sphere):
    V, F = sphere
    d = dl.heat_geodesic(V, F, [0])  # north pole
    assert d.shape == (len(V),) and d.dtype == np.float64
    exact = np.arccos(np.clip(V[:, 2], -1, 1))
    assert d[0] == pytest.approx(0, abs=1e-9)
    assert np.abs(d - exact).max() < 0.05 * np.pi


def test_fps(mesh):
    V, F = mesh
    s = dl.fps(V, F, 10)
    assert s.dtype == np.int64 and s.shape == (10,) and len(set(s.tolist())) == 10
    np.testing.assert_array_equal(s, dl.fps(V, F, 10, seed=0))
    g = dl.fps(V, F, 10, metric="geodesic", seed=3)
    assert len(set(g.tolist())) == 10


@pytest.mark.parametrize("mode", ["coupled", "per-handle"])
def test_bbw_properties(mesh, mode):
    V, F = mesh
    h = dl.fps(V, F, 5, seed=1)
    W = dl.bbw(V, F, h, mode=mode)
    assert W.shape == (len(V), 5) and W.dtype == np.float64
    assert W.min() >= 0 and W.max() <= 1
    np.testing.assert_allclose(W.sum(axis=1), 1, atol=1e-9)
    np.testing.assert_allclose(W[h], np.eye(5), atol=1e-12)


def test_bbw_tol_is_the_modes_tolerance(mesh):
    V, F = mesh
    h = dl.fps(V, F, 5, seed=1)
    for mode in ("per-handle", "coupled"):
        W = dl.bbw(V, F, h, mode=mode)
        tight = dl.bbw(V, F, h, mode=mode, tol=1e-13)
        loose = dl.bbw(V, F, h, mode=mode, tol=1e-3)
        # The default is within 1e-5 of a tight solve; a loose one is not
        # the same solve (the keyword reaches the solver).
        assert np.abs(W - tight).max() <= 1e-5
        assert np.abs(loose - tight).max() > np.abs(W - tight).max()
    for bad in (0.0, -1e-8, 1.0, float("nan")):
        with pytest.raises(ValueError, match="tol"):
            dl.bbw(V, F, h, tol=bad)


def test_select_keypoints_shapes(small_set):
    V, F = small_set["V"], small_set["F"]
    r = dl.select_keypoints((V[0][0], F), V[0][1:], n_candidates=30)
    k = len(r["keypoints"])
    assert k >= 1 and r["transforms"].shape == (2, k, 3, 4)
    assert r["trace"][-1][1] == r["keypoints"] or r["trace"][-1][2] >= r["error"] - 1e-12
    assert r["error"] <= r["trace"][0][2]


def test_transfer_self_reproduces_the_fit(small_set):
    """A → A′ transferred onto A itself with its own key points gives the fit D_S(A)."""
    V, F = small_set["V"], small_set["F"]
    A = (V[0][0], F)
    r = dl.transfer(A, V[0][1:], A, n_candidates=30)
    assert len(r["meshes"]) == 2
    assert r["meshes"][0].shape == V[0][0].shape
    assert r["keypoints"] == r["target_keypoints"]
    area = dl.massmatrix(*A).diagonal().sum()
    err = np.linalg.norm(r["meshes"][0] - V[0][1], axis=1).mean() / np.sqrt(area)
    floor = np.linalg.norm(V[0][0] - V[0][1], axis=1).mean() / np.sqrt(area)
    assert err < 0.25 * floor


@pytest.mark.parametrize("method", ["sumner", "cage", "sumner_oracle", "identity"])
def test_baselines(small_set, method):
    V, F = small_set["V"], small_set["F"]
    A, B = (V[0][0], F), (V[1][0], F)
    kp = dl.fps(V[0][0], F, 8, metric="geodesic").tolist()
    if method in ("sumner_oracle", "identity"):
        # These take no key points: giving them is refused, as on the CLI.
        with pytest.raises(ValueError, match="takes no key points"):
            dl.transfer(A, V[0][1:2], B, kp, keypoints=kp, method=method)
        r = dl.transfer(A, V[0][1:2], B, method=method)
    else:
        r = dl.transfer(A, V[0][1:2], B, kp, keypoints=kp, method=method)
    assert r["method"] == method and len(r["meshes"]) == 1
    err = np.linalg.norm(r["meshes"][0] - V[1][1], axis=1).mean()
    floor = np.linalg.norm(V[1][0] - V[1][1], axis=1).mean()
    if method == "identity":
        assert err == pytest.approx(floor)
    else:
        assert err < floor


def test_target_correspondence_finds_the_same_vertices(small_set):
    """Subjects share connectivity: the registration lands near the same vertex."""
    V, F = small_set["V"], small_set["F"]
    kp = dl.fps(V[0][0], F, 5, metric="geodesic").tolist()
    r = dl.target_correspondence((V[0][0], F), kp, (V[1][0], F))
    assert len(r["target_keypoints"]) == 5 and r["registered"].shape == V[0][0].shape
    area = dl.massmatrix(V[1][0], F).diagonal().sum()
    miss = np.linalg.norm(V[1][0][r["target_keypoints"]] - V[1][0][kp], axis=1) / np.sqrt(area)
    assert np.median(miss) < 0.1


def test_long_calls_release_the_gil(small_set):
    """While bbw runs in a thread, the main thread keeps running Python code:
    its longest pause is far shorter than the call."""
    import threading
    import time

    V, F = small_set["V"][0][0], small_set["F"]
    h = dl.fps(V, F, 6, seed=2)
    t0 = time.perf_counter()
    dl.bbw(V, F, h, mode="coupled")
    call = time.perf_counter() - t0
    done = {}

    def work():
        done["W"] = dl.bbw(V, F, h, mode="coupled")

    t = threading.Thread(target=work)
    t.start()
    last, gap = time.perf_counter(), 0.0
    while t.is_alive():
        now = time.perf_counter()
        gap, last = max(gap, now - last), now
    t.join()
    assert done["W"].shape == (len(V), 6)
    print(f"\nbbw {call:.3f} s; longest pause of the main thread meanwhile {gap:.4f} s")
    # Holding the GIL through the solve would pause the main thread for
    # about the whole call.
    assert gap < 0.5 * call, (gap, call)


def test_python_functions_run_as_methods(tmp_path):
    """run(config, methods={...}): a Python function evaluated like every
    method; an exception fails its case only."""
    cfg = tmp_path / "fn.toml"
    cfg.write_text(
        'name = "fn"\n[dataset.synthetic]\nsubjects = 2\nposes = 2\nresolution = 1\n'
        "[cases]\nsources = [0]\n"
        '[[methods]]\nname = "mine"\nkind = "callable"\nfunction = "shift"\nmarkers = true\n'
        '[[methods]]\nname = "broken"\nkind = "callable"\nfunction = "broken"\n'
        '[[methods]]\nname = "identity"\nkind = "identity"\n'
    )
    calls = []

    def shift(A, poses, B, markers):
        calls.append(len(markers))
        src = [s for s, _ in markers]
        return [B[0] + (P[src] - A[0][src]).mean(axis=0) for P in poses]

    def broken(A, poses, B, markers):
        raise RuntimeError("my bug")

    s = dl.run(cfg, out=tmp_path / "out", plots=False, methods={"shift": shift, "broken": broken})
    assert s[0]["failed"] == 1 and calls
    r = dl.load_results(s[0]["dir"])
    cases = r["cases"].set_index("method")
    assert cases.loc["mine", "status"] == "ok"
    assert "my bug" in cases.loc["broken", "status"]
    # A translation is rigid: after alignment it scores the floor.
    assert cases.loc["mine", "err_mean_area_rigid"] == pytest.approx(
        cases.loc["identity", "err_mean_area_rigid"], rel=1e-6)
    with pytest.raises(ValueError, match="expected a function"):
        dl.run(cfg, out=tmp_path / "out2", methods={"shift": 3})
    # Without the function the config does not load.
    with pytest.raises(Exception, match="shift"):
        dl.run(cfg, out=tmp_path / "out3")


class _TrimeshLike:
    """What trimesh.Trimesh offers a caller: .vertices and .faces."""

    def __init__(self, V, F):
        self.vertices, self.faces = V, F


def test_trimesh_like_objects_are_meshes(small_set):
    V, F = small_set["V"], small_set["F"]
    a = dl.transfer((V[0][0], F), [V[0][1]], (V[1][0], F), keypoints=[0, 100, 200], target_keypoints=[0, 100, 200])
    b = dl.transfer(_TrimeshLike(V[0][0], F), [_TrimeshLike(V[0][1], F)], _TrimeshLike(V[1][0], F),
                    keypoints=[0, 100, 200], target_keypoints=[0, 100, 200])
    np.testing.assert_array_equal(a["meshes"][0], b["meshes"][0])
    with pytest.raises(ValueError, match=r"\.vertices and \.faces"):
        dl.transfer(object(), [V[0][1]], (V[1][0], F))


def test_synthetic_returns_stacked_arrays(small_set):
    V = small_set["V"]
    assert isinstance(V, np.ndarray) and V.dtype == np.float64
    assert V.shape == (2, 3, small_set["labels"].shape[0], 3)
    np.testing.assert_array_equal(V[1, 2], V[1][2])

"""FBT from Python: registration to vertex constraints and shape completion
of a partial target, with the baselines through the same solver values."""

import numpy as np
import pytest

import deformlab as dl


@pytest.fixture(scope="module")
def fbt_case():
    s = dl.synthetic(subjects=1, poses=6, resolution=1)
    V, F = s["V"][0], s["F"]
    truth = V[5]  # never an example
    model = dl.FbtModel(V[:4], F, pipeline="lbo")
    area = dl.massmatrix(V[0], F).diagonal().sum()
    return model, V, F, truth, area


def _err(P, truth, area):
    return np.linalg.norm(P - truth, axis=1).mean() / np.sqrt(area)


def test_register_to_vertex_constraints(fbt_case):
    model, V, F, truth, area = fbt_case
    idx = dl.fps(V[0], F, 30, metric="geodesic").tolist()
    r = dl.register(model, (idx, truth[idx]))
    assert r["V"].shape == V[0].shape and r["V"].dtype == np.float64
    floor = _err(V[0], truth, area)
    err = _err(r["V"], truth, area)
    print(f"\nFBT register: error {err:.4f} vs template floor {floor:.4f} (√area units), α {r['alpha']:.3f}")
    assert err < 0.3 * floor
    assert abs(r["alpha"] - 1) < 0.05


def _partial(truth, F):
    """The truth without the faces of its +x third; (V, F) and the vertex map."""
    x = truth[:, 0]
    keep = (x[F] < np.quantile(x, 0.66)).all(axis=1)
    used = np.unique(F[keep])
    new = -np.ones(len(truth), dtype=np.int64)
    new[used] = np.arange(len(used))
    return (truth[used], new[F[keep]]), used, new


@pytest.mark.parametrize("solver", [None, "der", "amberg", "template"])
def test_complete_partial_target(fbt_case, solver):
    model, V, F, truth, area = fbt_case
    (PV, PF), used, new = _partial(truth, F)
    feats = [int(i) for i in dl.fps(PV, PF, 8, metric="geodesic", seed=1)]
    pairs = [(int(used[g]), g) for g in feats]  # template vertex = truth vertex (shared connectivity)
    r = dl.complete(model, (PV, PF), pairs, solver=solver)
    assert r["V"].shape == V[0].shape
    assert r["correspondence"].shape == (len(PV),) and r["correspondence"].dtype == np.int64
    floor = _err(V[0], truth, area)
    err = _err(r["V"], truth, area)
    # Correspondences: the template vertex matched to each partial vertex
    # vs the true one (the partial vertex's own index in the template).
    corr = np.linalg.norm(truth[r["correspondence"]] - truth[used], axis=1).mean() / np.sqrt(area)
    print(f"\ncomplete[{solver or 'fbt'}]: error {err:.4f}, correspondence {corr:.4f}, floor {floor:.4f}")
    if solver == "template":
        np.testing.assert_array_equal(r["V"], V[0])
    else:
        assert err < 0.6 * floor

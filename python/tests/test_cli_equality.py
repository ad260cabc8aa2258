"""The binding gives what the CLI gives for the same inputs and seeds.

Calls with no keyword options are compared with CLI runs with no flags:
the Python defaults are the library's defaults, as the CLI's are.
"""

import csv
import inspect as pyinspect
import json
import subprocess

import numpy as np
import pytest

import deformlab as dl

from conftest import REPO


def _run(cli, *args):
    r = subprocess.run([cli, *map(str, args)], capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr
    return r


def _keypoints_csv(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return [int(r["source"]) for r in rows], [int(r["target"]) for r in rows if r.get("target")]


def test_transfer_equals_cli(cli, synthetic_files, tmp_path):
    """`deformlab transfer --same-connectivity` vs `dl.transfer(A, A′, B)`, no options."""
    d = synthetic_files
    out = tmp_path / "cli"
    _run(cli, "transfer", "--source", d / "s0p0.ply", "--deformed", d / "s0p1.ply", d / "s0p2.ply",
         "--target", d / "s1p0.ply", "--same-connectivity", "--out", out)
    A = dl.read_mesh(d / "s0p0.ply")
    poses = [dl.read_mesh(d / f"s0p{p}.ply")[0] for p in (1, 2)]
    B = dl.read_mesh(d / "s1p0.ply")
    r = dl.transfer(A, poses, B, correspondence="identity")
    src, tgt = _keypoints_csv(out / "keypoints.csv")
    assert r["keypoints"] == src and r["target_keypoints"] == tgt
    log = json.loads((out / "log.json").read_text())
    assert r["fit_error"] == log["fit_error"]
    diffs = []
    for p, Vp in zip((1, 2), r["meshes"]):
        Vc, Fc = dl.read_mesh(out / f"s0p{p}_to_s1p0.ply")
        np.testing.assert_array_equal(Fc, B[1])
        diffs.append(float(np.abs(Vc - Vp).max()))
    print(f"\nCLI equality (transfer): key points {src}, fit error {r['fit_error']:.6f}, "
          f"max |B'_python - B'_cli| per pose {diffs}")
    assert max(diffs) == 0.0


def test_transfer_with_given_keypoints_equals_cli(cli, synthetic_files, tmp_path):
    """--keypoints FILE --target-keypoints i,j,k vs keypoints=..., target_keypoints=...,
    with options spelled as the CLI spells them."""
    d = synthetic_files
    out = tmp_path / "cli"
    kp = [12, 400, 900, 1300]
    tk = [12, 401, 905, 1300]
    kfile = tmp_path / "kp.csv"
    kfile.write_text("source\n" + "\n".join(map(str, kp)) + "\n")
    _run(cli, "transfer", "--source", d / "s0p0.ply", "--deformed", d / "s0p1.ply",
         "--target", d / "s1p0.ply", "--keypoints", kfile, "--target-keypoints", ",".join(map(str, tk)),
         "--frame", "handle-relative", "--weights", "coupled", "--seed", "3", "--out", out)
    A, B = dl.read_mesh(d / "s0p0.ply"), dl.read_mesh(d / "s1p0.ply")
    r = dl.transfer(A, [dl.read_mesh(d / "s0p1.ply")[0]], B, tk, keypoints=kp,
                    frame="handle_relative", weights="coupled", seed=3)
    Vc, _ = dl.read_mesh(out / "s0p1_to_s1p0.ply")
    diff = float(np.abs(Vc - r["meshes"][0]).max())
    print(f"\nCLI equality (given key points, handle-relative, coupled): max diff {diff}")
    assert diff == 0.0


def test_select_keypoints_equals_cli(cli, synthetic_files, tmp_path):
    d = synthetic_files
    out = tmp_path / "kp"
    _run(cli, "keypoints", "--source", d / "s1p0.ply", "--deformed", d / "s1p1.ply", d / "s1p2.ply",
         "--candidates", "40", "--seed", "2", "--out", out)
    A = dl.read_mesh(d / "s1p0.ply")
    poses = [dl.read_mesh(d / f"s1p{p}.ply")[0] for p in (1, 2)]
    r = dl.select_keypoints(A, poses, n_candidates=40, seed=2)
    src, _ = _keypoints_csv(out / "keypoints.csv")
    log = json.loads((out / "log.json").read_text())
    assert r["keypoints"] == src
    sel = log["selection"] if "selection" in log else log
    assert r["error"] == sel["error"]
    print(f"\nCLI equality (keypoints): {src}, error {r['error']:.6f}")


def test_run_equals_cli(cli, tmp_path):
    """`deformlab run` and `dl.run` on one config: the same cases.csv apart from timings."""
    cfg = REPO / "experiments" / "fig4.toml"
    _run(cli, "run", cfg, "--out", tmp_path / "cli", "--no-plots", "--quiet", "--set", "name=py-eq")
    s = dl.run(cfg, out=tmp_path / "py", overrides={"name": "py-eq"}, plots=False)
    assert s[0]["name"] == "py-eq" and s[0]["failed"] == 0 and s[0]["complete"]
    a = dl.load_results(tmp_path / "cli" / "py-eq")
    b = dl.load_results(s[0]["dir"])
    # cases.csv holds no timings (they are in timings/cases.csv): equal as is.
    assert not any(c.startswith("seconds") for c in a["cases"].columns)
    kp = [c for c in ("keypoints", "target_keypoints") if c in a["cases"].columns]
    assert a["cases"].drop(columns=kp).equals(b["cases"].drop(columns=kp))
    for c in kp:
        assert [x.tolist() for x in a["cases"][c]] == [x.tolist() for x in b["cases"][c]]
    assert len(a["cases"]) > 0
    assert "seconds_total" in a["timings"].columns and len(a["timings"]) == len(a["cases"])
    assert [i["computed"] for i in a["runs"]["invocations"]] == [len(a["cases"])]


def test_python_defaults_restate_no_numbers():
    """Every option keyword of the API defaults to None (the library's default)."""
    for fn in (dl.select_keypoints, dl.transfer, dl.bbw, dl.fps, dl.heat_geodesic, dl.massmatrix,
               dl.lbo_eigenpairs, dl.target_correspondence, dl.synthetic, dl.FbtModel.__init__,
               dl.complete):
        for p in pyinspect.signature(fn).parameters.values():
            if p.default is not pyinspect.Parameter.empty:
                assert p.default is None, f"{fn.__qualname__}({p.name}={p.default!r})"


def test_weight_mode_default_is_one(cli, synthetic_files, tmp_path):
    """One weight-mode default: `dl.bbw` without `mode`, `deformlab weights` without
    `--mode`, and the mode that key point selection and transfer use (`--weights`
    default, printed by `deformlab keypoints --help`) are the same, per-handle."""
    d = synthetic_files
    V, F = dl.read_mesh(d / "s0p0.ply")
    h = dl.fps(V, F, 5, seed=1)
    out = tmp_path / "w.csv"
    r = _run(cli, "weights", d / "s0p0.ply", "--handle-vertices", ",".join(map(str, h)), "--out", out)
    assert "mode: PerHandle" in r.stdout, r.stdout
    W_cli = np.loadtxt(out, delimiter=",")
    W_default = dl.bbw(V, F, h)
    np.testing.assert_array_equal(W_default, dl.bbw(V, F, h, mode="per-handle"))
    assert np.abs(W_default - dl.bbw(V, F, h, mode="coupled")).max() > 1e-6
    np.testing.assert_allclose(W_cli, W_default, atol=1e-15, rtol=0)
    for cmd in ("keypoints", "transfer", "weights"):
        text = " ".join(_run(cli, cmd, "--help").stdout.split())
        assert "[default: the library's, per-handle]" in text, f"{cmd} --help"


# Options per transfer kind, as the keys of a config entry (`--opt` on the CLI).
# Kinds not listed run with their defaults.
_EXAMPLE_METHOD = REPO / "scripts" / "examples" / "translate_method.py"
_KIND_OPTIONS = {
    "external": {"command": f"python3 {_EXAMPLE_METHOD} --source {{source}} --target {{target}} "
                            "--markers {markers} --out {out} {poses}"},
    "bdt": {"n_candidates": 24, "max_keypoints": 6},
    "bdt_random": {"count": 5, "seed": 3},
    "bdt_extremity": {"count": 5, "strategy": "centroid_fps"},
    "sumner": {"n_candidates": 24, "max_keypoints": 6},
    "cage": {"n_candidates": 24, "max_keypoints": 6},
}


def test_every_transfer_kind_equals_cli(cli, synthetic_files, tmp_path):
    """Every transfer kind of the registry: `dl.transfer(..., method=k, **options)`
    vs `deformlab transfer --method k --opt key=value`: the same B′."""
    assert set(_KIND_OPTIONS) <= set(dl.TRANSFER_METHODS), dl.TRANSFER_METHODS
    takes_keypoints = {k["name"]: "target_correspondence" in k["keys"] for k in dl.method_kinds()}
    d = synthetic_files
    A = dl.read_mesh(d / "s0p0.ply")
    poses = [dl.read_mesh(d / "s0p1.ply")[0]]
    B = dl.read_mesh(d / "s1p0.ply")
    diffs = {}
    # "callable" runs Python functions through run(methods=...): test_api.py.
    for kind in (k for k in dl.TRANSFER_METHODS if k != "callable"):
        opts = _KIND_OPTIONS.get(kind, {})
        out = tmp_path / kind
        flags = ["--same-connectivity"] if takes_keypoints[kind] else []
        for k, v in opts.items():
            flags += ["--opt", f"{k}={v}"]
        _run(cli, "transfer", "--source", d / "s0p0.ply", "--deformed", d / "s0p1.ply",
             "--target", d / "s1p0.ply", "--method", kind, *flags, "--out", out)
        corr = {"correspondence": "identity"} if takes_keypoints[kind] else {}
        r = dl.transfer(A, poses, B, method=kind, **corr, **opts)
        assert r["method"] == kind
        Vc, _ = dl.read_mesh(out / "s0p1_to_s1p0.ply")
        diffs[kind] = float(np.abs(Vc - r["meshes"][0]).max())
        if kind != "identity":
            assert float(np.abs(r["meshes"][0] - B[0]).max()) > 1e-3, kind
    print(f"\nCLI equality per kind: max |B'_python - B'_cli| {diffs}")
    assert max(diffs.values()) == 0.0


def test_method_options_are_checked_against_the_registry(synthetic_files):
    d = synthetic_files
    A = dl.read_mesh(d / "s0p0.ply")
    poses = [dl.read_mesh(d / "s0p1.ply")[0]]
    B = dl.read_mesh(d / "s1p0.ply")
    kinds = {k["name"]: k for k in dl.method_kinds()}
    assert "lambda" in kinds["bdt"]["keys"] and kinds["identity"]["keys"] == []
    with pytest.raises(ValueError, match=r"lambda.*does not apply to kind = \"identity\""):
        dl.transfer(A, poses, B, method="identity", **{"lambda": 0.3})
    with pytest.raises(ValueError, match=r"frame.*does not apply to kind = \"sumner\""):
        dl.transfer(A, poses, B, method="sumner", frame="raw")
    with pytest.raises(ValueError, match=r"no_such_key"):
        dl.transfer(A, poses, B, no_such_key=1)
    with pytest.raises(ValueError, match=r"epsilon"):
        dl.transfer(A, poses, B, epsilon=-1.0)
    with pytest.raises(ValueError, match=r"count"):
        dl.transfer(A, poses, B, method="bdt_random")
    with pytest.raises(ValueError, match=r"unknown transfer method"):
        dl.transfer(A, poses, B, method="clustering")

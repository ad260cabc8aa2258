"""Bad input: a ValueError naming the argument, never a crash of the interpreter.

Each case also runs in a subprocess so that an abort (a Rust panic across
FFI, a segfault) would show as a failed exit status, not a dead test run.
"""

import subprocess
import sys

import numpy as np
import pytest

import deformlab as dl



def _mesh():
    s = dl.synthetic(subjects=1, poses=2, resolution=1)
    return s["V"][0][0], s["F"], s["V"][0][1]


V, F, V1 = _mesh()
n = len(V)
nan_V = V.copy()
nan_V[7, 1] = np.nan
inf_V = V.copy()
inf_V[3, 0] = np.inf

CASES = {
    # name: (call, words the message must contain)
    "V 2 columns": (lambda: dl.cotmatrix(V[:, :2], F), ["V", "(n, 3)"]),
    "V 1-d": (lambda: dl.massmatrix(V.ravel(), F), ["V", "(n, 3)"]),
    "V empty": (lambda: dl.cotmatrix(np.zeros((0, 3)), F), ["V", "no vertices"]),
    "V NaN": (lambda: dl.bbw(nan_V, F, [0, 1]), ["V", "NaN", "vertex 7"]),
    "V inf": (lambda: dl.heat_geodesic(inf_V, F, [0]), ["V", "inf"]),
    "V strings": (lambda: dl.cotmatrix(np.array([["a", "b", "c"]]), F), ["V", "dtype"]),
    "F float": (lambda: dl.cotmatrix(V, F.astype(float)), ["F", "integer"]),
    "F 4 columns": (lambda: dl.cotmatrix(V, np.hstack([F, F[:, :1]])), ["F", "(m, 3)"]),
    "F out of range": (lambda: dl.cotmatrix(V, F + n), ["F", "out of range"]),
    "F negative": (lambda: dl.fps(V, F - 5, 3), ["F", "out of range"]),
    "F empty": (lambda: dl.cotmatrix(V, np.zeros((0, 3), dtype=int)), ["F", "no faces"]),
    "handle out of range": (lambda: dl.bbw(V, F, [0, n]), ["handles", "out of range"]),
    "handle negative": (lambda: dl.bbw(V, F, [-1, 3]), ["handles", "out of range"]),
    "handle twice": (lambda: dl.bbw(V, F, [4, 4]), ["handles", "twice"]),
    "no handles": (lambda: dl.bbw(V, F, []), ["handles"]),
    "bbw mode": (lambda: dl.bbw(V, F, [0, 9], mode="magic"), ["mode", "magic", "per-handle"]),
    "fps too many": (lambda: dl.fps(V, F, n + 1), ["k"]),
    "fps metric": (lambda: dl.fps(V, F, 3, metric="manhattan"), ["metric"]),
    "eigs k=0": (lambda: dl.lbo_eigenpairs(V, F, 0), ["k"]),
    "heat source": (lambda: dl.heat_geodesic(V, F, [n + 3]), ["sources", "out of range"]),
    "mass kind": (lambda: dl.massmatrix(V, F, kind="lumpy"), ["kind"]),
    "A not a pair": (lambda: dl.select_keypoints(V, [V1]), ["A", "(V, F)"]),
    "A_primes empty": (lambda: dl.select_keypoints((V, F), []), ["A_primes"]),
    "A_primes one array": (lambda: dl.select_keypoints((V, F), V1), ["A_primes"]),
    "A_primes wrong count": (lambda: dl.select_keypoints((V, F), [V1[:-1]]), ["A_primes[0]", "vertices"]),
    "A_primes NaN": (lambda: dl.select_keypoints((V, F), [nan_V]), ["A_primes[0]", "NaN"]),
    "epsilon negative": (lambda: dl.select_keypoints((V, F), [V1], epsilon=-1.0), ["epsilon"]),
    "epsilon NaN": (lambda: dl.select_keypoints((V, F), [V1], epsilon=float("nan")), ["epsilon"]),
    "candidates 0": (lambda: dl.select_keypoints((V, F), [V1], n_candidates=0), ["n_candidates"]),
    "candidates > n": (lambda: dl.select_keypoints((V, F), [V1], n_candidates=n + 1), ["n_candidates"]),
    "selection mode": (lambda: dl.select_keypoints((V, F), [V1], mode="slow"), ["mode", "exact"]),
    "keypoint out of range": (lambda: dl.transfer((V, F), [V1], (V, F), keypoints=[1, n]), ["keypoints", "out of range"]),
    "target kp without kp": (lambda: dl.transfer((V, F), [V1], (V, F), [1, 2]), ["target_keypoints", "keypoints"]),
    "target kp count": (lambda: dl.transfer((V, F), [V1], (V, F), [1, 2], keypoints=[1, 2, 3]), ["target_keypoints"]),
    "target kp range": (lambda: dl.transfer((V, F), [V1], (V, F), [1, n], keypoints=[1, 2]), ["target_keypoints", "out of range"]),
    "identity needs same n": (lambda: dl.transfer((V, F), [V1], (V[:-1], F[:10]), keypoints=[1, 2]), ["vertices"]),
    "method": (lambda: dl.transfer((V, F), [V1], (V, F), method="magic"), ["method"]),
    "frame": (lambda: dl.transfer((V, F), [V1], (V, F), keypoints=[1, 2], frame="sideways"), ["frame"]),
    "correspondence": (lambda: dl.transfer((V, F), [V1], (V, F), keypoints=[1, 2], correspondence="psychic"), ["correspondence"]),
    "landmarks without auto": (lambda: dl.transfer((V, F), [V1], (V, F), keypoints=[1, 2], landmarks=[[1, 1]]), ["landmarks"]),
    "landmarks shape": (lambda: dl.target_correspondence((V, F), [1], (V, F), landmarks=[1, 2, 3]), ["landmarks"]),
    "fbt no examples": (lambda: dl.FbtModel([], F), ["examples"]),
    "fbt example count": (lambda: dl.FbtModel([V, V1[:-2]], F), ["examples[1]"]),
    "fbt skeleton needs rig": (lambda: dl.FbtModel([V], F, pipeline="skeleton"), ["rig"]),
    "fbt pipeline": (lambda: dl.FbtModel([V, V1], F, pipeline="wavy"), ["pipeline"]),
    "register targets": (lambda: dl.register(dl.FbtModel([V, V1], F, pipeline="lbo"), ([1, 2], np.zeros((3, 3)))), ["targets"]),
    "register vertex": (lambda: dl.register(dl.FbtModel([V, V1], F, pipeline="lbo"), ([n], np.zeros((1, 3)))), ["vertices", "out of range"]),
    "complete features": (lambda: dl.complete(dl.FbtModel([V, V1], F, pipeline="lbo"), (V, F), [[0, n]]), ["features", "out of range"]),
    "complete solver": (lambda: dl.complete(dl.FbtModel([V, V1], F, pipeline="lbo"), (V, F), [[0, 0]], solver="x"), ["solver"]),
    "synthetic resolution": (lambda: dl.synthetic(resolution=9), ["resolution"]),
    "synthetic negative": (lambda: dl.synthetic(subjects=-1), ["subjects"]),
    "run overrides string": (lambda: dl.run("experiments/fig4.toml", overrides="a=b"), ["overrides"]),
    "run missing config": (lambda: dl.run("/nonexistent/x.toml", out="/tmp/never"), ["x.toml"]),
    "bad file": (lambda: dl.read_mesh(__file__), ["test_bad_input.py"]),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_value_error(name):
    call, words = CASES[name]
    with pytest.raises((ValueError, OSError)) as e:
        call()
    if name not in ("run missing config",):
        assert e.type is ValueError, f"{name}: {e.type.__name__}: {e.value}"
    msg = str(e.value)
    for w in words:
        assert w in msg, f"{name}: {w!r} not in {msg!r}"


def test_no_case_crashes_the_interpreter():
    """All cases again in a fresh interpreter: it must exit normally."""
    code = (
        "import sys; sys.path.insert(0, %r)\n"
        "import test_bad_input as t\n"
        "for name, (call, _) in sorted(t.CASES.items()):\n"
        "    try:\n"
        "        call()\n"
        "    except (ValueError, OSError):\n"
        "        pass\n"
        "print('survived', len(t.CASES))\n"
    ) % str(__import__("pathlib").Path(__file__).parent)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    assert f"survived {len(CASES)}" in r.stdout

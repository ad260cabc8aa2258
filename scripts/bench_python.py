#!/usr/bin/env python3
"""Binding overhead: bbw and transfer from Python vs the CLI on a FAUST mesh.

    python scripts/bench_python.py [--reps 3] [--auto] [--data DIR] [--cli PATH]

A benchmark, not a test: it prints medians of several runs and `uptime`
(the machine may be shared). FAUST: A = tr_reg_001 (subject 0), A′ =
tr_reg_003 and tr_reg_007, B = tr_reg_012 (subject 1), 6890 vertices each,
with the same given key points (FPS, geodesic, seed 0) on both sides.

* transfer: `deformlab transfer --keypoints FILE --target-keypoints ...`
  (the process's wall time, and the `seconds.total` its log.json reports,
  which includes reading and writing the meshes) against
  `deformlab.transfer(A, A′, B, tk, keypoints=kp)` (wall time of the call,
  meshes already in memory), first in a fresh interpreter per run, then
  repeated in one process (where the library's in-process memo of the fit
  on A makes it cheaper); the results are compared too.
* bbw: the CLI has no bbw command; its transfer logs the time of the
  bounded biharmonic weights on B (`seconds.target_weights`: the library's
  default per-handle weights at the target key points), against
  `deformlab.bbw(B, tk, mode="per-handle")` from Python.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import deformlab as dl

ROOT = Path(__file__).resolve().parents[1]


def uptime() -> str:
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    except OSError:
        return "(uptime unavailable)"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--keypoints", type=int, default=6, help="key points (FPS on A)")
    ap.add_argument("--auto", action="store_true",
                    help="also time transfer with automatic key point selection (Algorithm 1, fast mode)")
    ap.add_argument("--data", default=os.environ.get("DEFORMLAB_DATA") or str(ROOT.parent / "shared" / "data"))
    ap.add_argument("--cli", default=os.environ.get("DEFORMLAB_CLI") or str(ROOT / "target" / "release" / "deformlab"))
    a = ap.parse_args()
    faust = Path(a.data) / "faust"
    files = {k: faust / f"tr_reg_{k}.ply" for k in ("001", "003", "007", "012")}
    if not all(p.is_file() for p in files.values()):
        print(f"SKIP: FAUST meshes not found under {faust} (set DEFORMLAB_DATA or --data)")
        return 0
    if not os.access(a.cli, os.X_OK):
        print(f"no CLI binary at {a.cli}: build it with cargo build --release (or --cli PATH)")
        return 1
    A = dl.read_mesh(files["001"])
    poses = [dl.read_mesh(files[k])[0] for k in ("003", "007")]
    B = dl.read_mesh(files["012"])
    kp = dl.fps(A[0], A[1], a.keypoints, metric="geodesic").tolist()
    tk = kp  # FAUST registrations share connectivity
    print(f"deformlab {dl.__version__}; FAUST {len(A[0])} vertices; {len(kp)} key points {kp}; {a.reps} runs each")
    print(f"uptime before: {uptime()}")

    cli_wall, cli_total, cli_weights, py_transfer, py_repeat, py_bbw = [], [], [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        kfile = Path(tmp) / "kp.csv"
        kfile.write_text("source\n" + "\n".join(map(str, kp)) + "\n")
        last_cli = None
        for r in range(a.reps):
            out = Path(tmp) / f"cli{r}"
            t = time.perf_counter()
            p = subprocess.run(
                [a.cli, "transfer", "--source", files["001"], "--deformed", files["003"], files["007"],
                 "--target", files["012"], "--keypoints", kfile, "--target-keypoints", ",".join(map(str, tk)),
                 "--out", out],
                capture_output=True, text=True,
            )
            cli_wall.append(time.perf_counter() - t)
            if p.returncode != 0:
                print(p.stderr)
                return 1
            log = json.loads((out / "log.json").read_text())
            cli_total.append(log["seconds"]["total"])
            cli_weights.append(log["seconds"]["target_weights"])
            last_cli = out
        # A fresh interpreter per run: the library memoises the fit on A
        # within a process, so a repeated call in one process skips it (timed
        # separately below).
        code = (
            "import sys, time, deformlab as dl\n"
            "A = dl.read_mesh(sys.argv[1]); P = [dl.read_mesh(p)[0] for p in sys.argv[2:4]]\n"
            "B = dl.read_mesh(sys.argv[4]); kp = [int(x) for x in sys.argv[5].split(',')]\n"
            "t = time.perf_counter(); dl.transfer(A, P, B, kp, keypoints=kp)\n"
            "print(time.perf_counter() - t)\n"
        )
        for r in range(a.reps):
            p = subprocess.run(
                [sys.executable, "-c", code, files["001"], files["003"], files["007"], files["012"],
                 ",".join(map(str, kp))],
                capture_output=True, text=True, check=True,
            )
            py_transfer.append(float(p.stdout.split()[-1]))
        res = dl.transfer(A, poses, B, tk, keypoints=kp)
        for r in range(a.reps):
            t = time.perf_counter()
            res = dl.transfer(A, poses, B, tk, keypoints=kp)
            py_repeat.append(time.perf_counter() - t)
        for r in range(a.reps):
            t = time.perf_counter()
            W = dl.bbw(B[0], B[1], tk, mode="per-handle")
            py_bbw.append(time.perf_counter() - t)
        diff = max(
            float(np.abs(dl.read_mesh(last_cli / f"tr_reg_{k}_to_tr_reg_012.ply")[0] - Vp).max())
            for k, Vp in zip(("003", "007"), res["meshes"])
        )
    med = statistics.median
    fmt = lambda xs: f"median {med(xs):.3f} s  (runs: {', '.join(f'{x:.3f}' for x in xs)})"  # noqa: E731
    print(f"transfer, CLI process wall      : {fmt(cli_wall)}")
    print(f"transfer, CLI log seconds.total : {fmt(cli_total)}")
    print(f"transfer, Python dl.transfer, first call in a process: {fmt(py_transfer)}")
    print(f"transfer, Python dl.transfer, repeated (fit memoised): {fmt(py_repeat)}")
    print(f"  max |B'_python - B'_cli| = {diff:.3e}")
    print(f"bbw on B, CLI (seconds.target_weights): {fmt(cli_weights)}")
    print(f"bbw on B, Python dl.bbw             : {fmt(py_bbw)}  W {W.shape}")
    if a.auto:
        auto_cli, auto_py = [], []
        with tempfile.TemporaryDirectory() as tmp:
            for r in range(a.reps):
                out = Path(tmp) / f"auto{r}"
                t = time.perf_counter()
                subprocess.run(
                    [a.cli, "transfer", "--source", files["001"], "--deformed", files["003"], files["007"],
                     "--target", files["012"], "--same-connectivity", "--out", out],
                    capture_output=True, text=True, check=True,
                )
                auto_cli.append(time.perf_counter() - t)
            code = (
                "import sys, time, deformlab as dl\n"
                "A = dl.read_mesh(sys.argv[1]); P = [dl.read_mesh(p)[0] for p in sys.argv[2:4]]\n"
                "B = dl.read_mesh(sys.argv[4])\n"
                "t = time.perf_counter(); r = dl.transfer(A, P, B)\n"
                "print(r['keypoints']); print(time.perf_counter() - t)\n"
            )
            for r in range(a.reps):
                p = subprocess.run(
                    [sys.executable, "-c", code, files["001"], files["003"], files["007"], files["012"]],
                    capture_output=True, text=True, check=True,
                )
                auto_py.append(float(p.stdout.split()[-1]))
            cli_kp = _keypoints(Path(tmp) / f"auto{a.reps - 1}" / "keypoints.csv")
        print(f"transfer with automatic selection, CLI process wall : {fmt(auto_cli)}")
        print(f"transfer with automatic selection, Python (fresh)   : {fmt(auto_py)}")
        print(f"  key points: CLI {cli_kp}, Python {p.stdout.splitlines()[0]}")
    print(f"uptime after: {uptime()}")
    return 0


def _keypoints(path: Path):
    rows = path.read_text().splitlines()[1:]
    return [int(r.split(",")[0]) for r in rows]


if __name__ == "__main__":
    sys.exit(main())

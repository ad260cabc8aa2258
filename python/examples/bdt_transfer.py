"""BDT deformation transfer on the synthetic set, shown in polyscope if installed.

    python python/examples/bdt_transfer.py [--no-show] [--out DIR] [--screenshot FILE.png]

Subject 0 (rest pose A and two deformed poses A′) is transferred to
subject 1 (B) with automatically selected key points; the synthetic set
has an exact ground truth (subject 1 in the same poses), so the script
prints the error of each B′ in √area(B) units and, with polyscope, shows
A, A′, B, B′ (coloured by the error) and the truth side by side.
"""

import argparse
import sys

import numpy as np

import deformlab as dl


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-show", action="store_true", help="do not open the polyscope viewer")
    ap.add_argument("--out", help="write B′ as PLY files into this folder")
    ap.add_argument("--screenshot", help="render the scene headless (EGL) into this PNG instead of a window")
    args = ap.parse_args()

    s = dl.synthetic(subjects=2, poses=3, resolution=1)
    V, F = s["V"], s["F"]
    A, B = (V[0][0], F), (V[1][0], F)
    r = dl.transfer(A, V[0][1:], B)  # every option: the library's default
    print(f"deformlab {dl.__version__}: {len(r['keypoints'])} key points {r['keypoints']}, "
          f"fit error {r['fit_error']:.4f} (unit sphere)")
    sqrt_area = np.sqrt(dl.massmatrix(*B).diagonal().sum())
    errors = []
    for j, Bp in enumerate(r["meshes"]):
        e = np.linalg.norm(Bp - V[1][j + 1], axis=1) / sqrt_area
        errors.append(e)
        print(f"pose {j + 1}: mean error {e.mean():.4f} √area(B), "
              f"identity floor {np.linalg.norm(V[1][0] - V[1][j + 1], axis=1).mean() / sqrt_area:.4f}")
        if args.out:
            import os

            os.makedirs(args.out, exist_ok=True)
            dl.write_mesh(os.path.join(args.out, f"b_prime_{j + 1}.ply"), Bp, F)

    if args.no_show:
        return 0
    try:
        import polyscope as ps
    except ImportError:
        print("polyscope is not installed (pip install polyscope): skipping the viewer")
        return 0
    import os

    if not args.screenshot and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        print("no display: skipping the viewer (--screenshot FILE.png renders headless)")
        return 0
    try:
        if args.screenshot:
            ps.set_allow_headless_backends(True)
        ps.init()
    except Exception as e:  # no OpenGL
        print(f"polyscope could not start ({e}): skipping the viewer")
        return 0
    width = np.ptp(V[0][0][:, 0]) * 1.3
    shift = lambda X, k: X + np.array([k * width, 0, 0])  # noqa: E731
    ps.register_surface_mesh("A", shift(V[0][0], 0), F)
    ps.register_surface_mesh("A'", shift(V[0][1], 1), F)
    ps.register_surface_mesh("B", shift(V[1][0], 2), F)
    m = ps.register_surface_mesh("B' (BDT)", shift(r["meshes"][0], 3), F)
    m.add_scalar_quantity("error (sqrt area)", errors[0], enabled=True)
    ps.register_surface_mesh("truth", shift(V[1][1], 4), F)
    kp = np.asarray(r["target_keypoints"])
    ps.register_point_cloud("key points on B", shift(V[1][0][kp], 2), radius=0.01)
    ps.set_ground_plane_mode("none")
    lo, hi = V[0][0].min(axis=0), V[0][0].max(axis=0)
    centre = np.array([2 * width + 0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])])
    ps.look_at(tuple(centre + np.array([0.0, 0.15 * width, 4.2 * width])), tuple(centre))
    if args.screenshot:
        ps.screenshot(args.screenshot, transparent_bg=False)
        print(f"wrote {args.screenshot}")
    else:
        ps.show()
    return 0


if __name__ == "__main__":
    sys.exit(main())

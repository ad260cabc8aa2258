//! Metrics on the synthetic set: properties that tie independent
//! computations together.

use deformlab::data::synthetic::FaustStyle;
use deformlab::eval::{
    aligned_vertex_errors, arap_energy, cumulative_curve, curve_grid, distortion, error_stats,
    vertex_errors, ErrorScale,
};
use deformlab::ops::total_area;

#[test]
fn procrustes_never_increases_the_rms_error_and_units_convert_consistently() {
    let set = FaustStyle {
        subjects: 2,
        poses: 4,
        resolution: 1,
        ..Default::default()
    }
    .generate()
    .unwrap();
    let b = &set.meshes[1][0];
    let scale = ErrorScale::of_reference(b).unwrap();
    assert!((scale.sqrt_area - total_area(b).sqrt().recip()).abs() < 1e-15);
    for p in 0..4 {
        let r = &set.meshes[0][p];
        let t = &set.meshes[1][p];
        let raw = error_stats(&vertex_errors(r.vertices(), t.vertices()).unwrap()).unwrap();
        let al = error_stats(&aligned_vertex_errors(r.vertices(), t.vertices()).unwrap()).unwrap();
        // Procrustes minimises the sum of squares: RMS can only go down.
        assert!(al.rms <= raw.rms + 1e-12, "pose {p}: {al:?} vs {raw:?}");
        // Units are one factor each.
        let u = raw.scaled(scale.unit_sphere);
        let a = raw.scaled(scale.sqrt_area);
        assert!((u.mean / a.mean - scale.unit_sphere / scale.sqrt_area).abs() < 1e-9);
        // The truth itself: zero error, a curve at 1 everywhere, zero energy.
        let zero = vertex_errors(t.vertices(), t.vertices()).unwrap();
        let grid = curve_grid(0.1, 5).unwrap();
        assert!(cumulative_curve(&zero, &grid).iter().all(|&f| f == 1.0));
        assert!(arap_energy(t, t.vertices()).unwrap().1 < 1e-20);
        assert!(distortion(t, t.vertices()).unwrap().area_log_max_abs < 1e-12);
    }
    // A posed mesh is not an isometry of its reference pose: energy > 0,
    // but far below a 20% uniform scaling ((1.2 − 1)² = 0.04).
    let e = arap_energy(b, set.meshes[1][2].vertices()).unwrap().1;
    assert!(e > 1e-6 && e < 0.04, "{e}");
}

//! Automatic feature correspondence (FBT Fig. 3): among the 24 assignments
//! of the four limb tips (two hands, two feet) the minimal E_mn picks the
//! true one.

use deformlab::data::synthetic::FaustStyle;
use deformlab::register::*;
use deformlab::Mesh;

/// Vertex of `bone` farthest from the centroid (rest pose): limb tips.
fn tip(rest: &Mesh, labels: &[usize], bone: usize) -> usize {
    let v = rest.vertices();
    let c = v
        .iter()
        .fold(nalgebra::Vector3::zeros(), |a, p| a + p.coords)
        / v.len() as f64;
    (0..v.len())
        .filter(|&i| labels[i] == bone)
        .max_by(|&a, &b| {
            (v[a].coords - c)
                .norm()
                .total_cmp(&(v[b].coords - c).norm())
        })
        .unwrap()
}

#[test]
fn permutation_search_finds_the_true_limb_assignment() {
    let set = FaustStyle {
        subjects: 1,
        poses: 10,
        seed: 0,
        resolution: 1,
        tail: true,
        spread: 0.15,
    }
    .generate()
    .unwrap();
    let mut meshes = vec![set.rest[0].clone()];
    meshes.extend(set.meshes[0].iter().cloned());
    let name = |s: &str| set.bone_names.iter().position(|b| *b == s).unwrap();
    // Features: forearm_l, forearm_r, shin_l, shin_r tips (ambiguous
    // group), head, tail tip, and the tips of chest and pelvis.
    let feats: Vec<usize> = [
        "forearm_l",
        "forearm_r",
        "shin_l",
        "shin_r",
        "head",
        "tail_tip",
        "chest",
        "pelvis",
    ]
    .iter()
    .map(|b| tip(&meshes[0], &set.labels, name(b)))
    .collect();
    let group = feature_row_groups(4, 10);
    let params = FbtParams::default();
    // Trials: (examples, target) with the target held out.
    let trials: Vec<(Vec<usize>, usize)> = vec![
        (vec![0, 1, 2, 3], 7),
        (vec![0, 1, 2, 3], 8),
        (vec![0, 2, 4, 6], 9),
        (vec![0, 2, 4, 6], 10),
        (vec![1, 3, 5, 7], 2),
        (vec![1, 3, 5, 7], 9),
        (vec![0, 5, 8, 10], 7),
        (vec![0, 5, 8, 10], 3),
        (vec![2, 4, 7, 9], 8),
        (vec![2, 4, 7, 9], 6),
        (vec![0, 3, 6, 9], 1),
        (vec![0, 3, 6, 9], 5),
        (vec![1, 4, 7, 10], 2),
        (vec![1, 4, 7, 10], 8),
        (vec![0, 1], 4),
        (vec![2, 8], 5),
        (vec![3, 5, 9], 10),
        (vec![4, 6, 10], 1),
        (vec![0, 2, 5, 7, 9], 3),
        (vec![1, 3, 6, 8, 10], 4),
    ];
    let mut right = 0;
    for (examples, target) in &trials {
        let ex: Vec<Mesh> = examples.iter().map(|&i| meshes[i].clone()).collect();
        let setup = build(&ex, &FbtConfig::default()).unwrap();
        let radii = circle_radii(10, 0.1 * setup.graph.area().sqrt());
        let pairs: Vec<(usize, usize)> = feats.iter().map(|&f| (f, f)).collect();
        let (rows, y) =
            feature_circle_constraints(&ex[0], &meshes[*target], &pairs, &radii).unwrap();
        let sys = setup.pipeline.systems(&rows, &params).unwrap();
        let search = best_permutation(&sys, &y, &group, &Schedule::default()).unwrap();
        let truth = search
            .energies
            .iter()
            .find(|(p, _)| p == &vec![0, 1, 2, 3])
            .unwrap()
            .1;
        let mut sorted: Vec<f64> = search.energies.iter().map(|e| e.1).collect();
        sorted.sort_by(f64::total_cmp);
        let ok = search.best == vec![0, 1, 2, 3];
        right += ok as usize;
        eprintln!(
            "examples {examples:?} target {target}: chose {:?} ({}) E_true {truth:.4} best {:.4} second {:.4}",
            search.best,
            if ok { "right" } else { "WRONG" },
            sorted[0],
            sorted[1]
        );
    }
    let rate = right as f64 / trials.len() as f64;
    eprintln!(
        "true assignment chosen in {right}/{} trials ({:.0} %)",
        trials.len(),
        100.0 * rate
    );
    assert!(rate >= 0.9, "rate {rate}");
}

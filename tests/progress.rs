//! Progress reports of long steps (`solve::progress`): a selection reports
//! its stages and trial counts and the weights their handles, counts stay
//! within their totals, and installing a sink changes no result. One test
//! in its own binary: the sink is process-wide.

use std::sync::{Arc, Mutex};

use deformlab::data::synthetic::FaustStyle;
use deformlab::solve::progress::{self, ProgressSink};
use deformlab::transfer::keypoints::{select_keypoints, KeypointOptions, SelectionMode};

#[derive(Default)]
struct Recorder(Mutex<Vec<(String, usize, usize)>>);

impl ProgressSink for Recorder {
    fn update(&self, step: &str, done: usize, total: usize) {
        self.0.lock().unwrap().push((step.to_string(), done, total));
    }
}

#[test]
fn selection_reports_its_steps_and_a_sink_changes_nothing() {
    let set = FaustStyle {
        subjects: 1,
        poses: 3,
        resolution: 1,
        ..Default::default()
    }
    .generate()
    .unwrap();
    let (a, d) = (set.meshes[0][0].clone(), set.meshes[0][1..].to_vec());
    let opts = KeypointOptions {
        n_candidates: 12,
        epsilon: 0.0,
        max_keypoints: 3,
        mode: SelectionMode::Fast,
        max_swap_passes: 1,
        ..Default::default()
    };
    assert!(!progress::enabled());
    let quiet = select_keypoints(&a, &d, &opts).unwrap();
    let rec = Arc::new(Recorder::default());
    let reported = {
        let _guard = progress::install(rec.clone());
        assert!(progress::enabled());
        select_keypoints(&a, &d, &opts).unwrap()
    };
    // The guard is dropped: no sink, and nothing more is recorded.
    assert!(!progress::enabled());
    let n = rec.0.lock().unwrap().len();
    progress::update("after", 1, 1);
    assert_eq!(rec.0.lock().unwrap().len(), n);

    assert_eq!(quiet.keypoints, reported.keypoints);
    assert_eq!(quiet.error.to_bits(), reported.error.to_bits());
    let log = rec.0.lock().unwrap();
    let has = |s: &str| log.iter().any(|(step, _, _)| step.contains(s));
    assert!(has("key points: stage 1"), "{:?}", &log[..log.len().min(5)]);
    assert!(has("key points: stage 2"));
    assert!(has("screening trial") && has("exact trial"));
    assert!(has("bounded biharmonic weights"));
    for (step, done, total) in log.iter() {
        assert!(*total == 0 || done <= total, "{step}: {done}/{total}");
    }
    // Every screening step reaches its total (each trial reports once).
    let screening: Vec<_> = log
        .iter()
        .filter(|(s, _, t)| s.contains("screening trial") && *t > 0)
        .collect();
    assert!(screening.iter().any(|(_, d, t)| d == t));
}

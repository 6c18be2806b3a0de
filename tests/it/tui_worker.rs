//! The solve worker: newest request wins, replies come in generation order, stale requests are dropped or
//! cancelled, and the basis is trained once per training set.

use crate::tui_support;

use metamer::tui::worker::{BasisMode, Reply, Worker, WorkerConfig};
use std::time::Duration;

#[test]
fn the_newest_palette_is_always_solved_last() {
    let mut worker =
        Worker::start(WorkerConfig { time_limit: Duration::from_secs(30), basis: BasisMode::Off }).expect("threads");
    let mut palette = tui_support::demo_palette();
    for generation in 1..=20u64 {
        palette.colours[0].weight = generation as f64;
        worker.submit(generation, &palette);
    }
    let mut seen = Vec::new();
    while worker.busy() {
        match worker.wait_reply(Duration::from_secs(60)) {
            Some(Reply::Solved(s)) => {
                if s.generation < 20 {
                    // An older palette: either solved before the newer one arrived, or cancelled.
                    assert!(s.result.is_ok() || s.result.as_ref().is_err_and(|e| e.to_string().contains("cancel")));
                } else {
                    let solution = s.result.expect("the newest palette solves");
                    assert_eq!(solution.palette.colours[0].weight, 20.0);
                }
                seen.push(s.generation);
            }
            Some(Reply::Trained(_)) => panic!("basis training is off"),
            None => panic!("the worker stopped answering"),
        }
    }
    assert_eq!(seen.last(), Some(&20));
    assert!(seen.windows(2).all(|w| w[0] < w[1]), "replies in generation order: {seen:?}");
    assert!(seen.len() <= 20);
}

#[test]
fn the_basis_is_trained_once_per_training_set() {
    use metamer::basis::TrainingSet;
    use metamer::tui::model::BasisKey;
    let mut worker =
        Worker::start(WorkerConfig { time_limit: Duration::from_secs(30), basis: BasisMode::Train { sidecar: None } })
            .expect("threads");
    let mut palette = tui_support::demo_palette();
    // Solving alone trains nothing (the demo palette's criteria do not use the basis).
    worker.submit(1, &palette);
    assert!(!worker.training());
    let set = TrainingSet::from_palette(&palette).expect("spectra");
    let key = BasisKey::of(&set, 7);
    worker.request_basis(1, key.clone(), set.clone(), 7);
    assert!(worker.training());
    // The same spectra again (a target edit keeps them): no second training is asked for.
    palette.colours[0].weight = 3.0;
    worker.submit(2, &palette);
    worker.request_basis(2, key.clone(), set.clone(), 7);
    let mut trained = 0;
    while worker.busy() {
        match worker.wait_reply(Duration::from_secs(120)) {
            Some(Reply::Trained(t)) => {
                assert_eq!((t.generation, &t.key), (1, &key));
                assert_eq!(t.result.expect("trains").0.dimension(), 7);
                trained += 1;
            }
            Some(Reply::Solved(_)) => {}
            None => panic!("the worker stopped answering"),
        }
    }
    assert_eq!(trained, 1);
    // A new dimension is a new training set.
    worker.request_basis(3, BasisKey::of(&set, 5), set, 5);
    assert!(worker.training());
}

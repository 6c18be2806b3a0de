use super::*;

#[test]
fn tick_labels_are_short_and_exact() {
    assert_eq!(tick_label(0.001), "0.001");
    assert_eq!(tick_label(0.00999999), "0.01");
    assert_eq!(tick_label(2.5), "2.5");
    assert_eq!(tick_label(30.0), "30");
    assert_eq!(tick_label(1e-5), "1e-5");
    assert_eq!(tick_label(3.2e6), "3.2e6");
    assert_eq!(tick_label(0.0), "0");
    assert!((1..200).map(|i| tick_label(i as f64 * 1.1e-4)).all(|s| s.len() <= 7));
}

/// Ranges the bench plots meet (basis error 0.016…40, solve 1e-4…10, render 0.9…13 ms, narrow ones).
const DATA: [(f64, f64); 8] =
    [(0.016, 40.0), (1e-4, 9.0), (0.9, 13.0), (0.02, 0.03), (2.5, 10.1), (0.0013, 2.1), (3e-7, 0.8), (1.0, 1.0)];

#[test]
fn log_axes_label_both_ends_and_never_repeat_a_label() {
    for (lo, hi) in DATA {
        let (a, b) = range([lo, hi].into_iter(), Scale::Log).unwrap();
        assert!(a <= lo && b >= hi, "{lo}…{hi} plotted as {a}…{b}");
        for max_labels in [4, 8, 16] {
            let t = axis_ticks(a, b, Scale::Log, max_labels);
            assert!(t.bold.len() >= 2 && t.bold.len() <= max_labels + 2, "{lo}…{hi}: {:?}", t.bold);
            assert!(t.bold.windows(2).all(|w| w[0] < w[1]), "{:?}", t.bold);
            assert!(t.bold.iter().all(|v| *v >= a * (1.0 - 1e-9) && *v <= b * (1.0 + 1e-9)), "{:?}", t.bold);
            // The ends of the axis are labelled as densely as its inside: no unlabelled decade at an end when
            // every decade is labelled, never a longer stretch than between two labels when they are thinned.
            let (first, last) = (t.bold[0], t.bold[t.bold.len() - 1]);
            let spacing = t.bold.windows(2).map(|w| w[1].log10() - w[0].log10()).fold(0.5, f64::max);
            assert!(first.log10() - a.log10() <= spacing, "{lo}…{hi}: first label {first} far above {a}");
            assert!(b.log10() - last.log10() <= spacing, "{lo}…{hi}: last label {last} far below {b}");
            let labels: Vec<String> = t.bold.iter().map(|v| tick_label(*v)).collect();
            let mut unique = labels.clone();
            unique.dedup();
            assert_eq!(labels, unique, "a label drawn twice");
            assert!(t.light.iter().all(|l| !t.bold.iter().any(|b| (b - l).abs() < 1e-12 * b)));
        }
    }
}

#[test]
fn linear_axes_use_round_steps_within_the_label_budget() {
    for (lo, hi) in DATA {
        let (a, b) = range([lo, hi].into_iter(), Scale::Linear).unwrap();
        for max_labels in [4, 8, 11] {
            let t = axis_ticks(a, b, Scale::Linear, max_labels);
            assert!(t.bold.len() >= 2 && t.bold.len() <= max_labels, "{a}…{b} ({max_labels}): {:?}", t.bold);
            let labels: Vec<String> = t.bold.iter().map(|v| tick_label(*v)).collect();
            let mut unique = labels.clone();
            unique.dedup();
            assert_eq!(labels, unique, "{a}…{b}: {labels:?}");
        }
    }
    assert_eq!(axis_ticks(2.0, 12.6, Scale::Linear, 11).bold, (2..=12).map(f64::from).collect::<Vec<_>>());
}

#[test]
fn every_series_gets_its_own_colour_and_marker() {
    // Every series of a plot up to COLOURS.len() has a colour of its own …
    for i in 0..COLOURS.len() {
        for j in 0..i {
            assert!(style_of(i).0 != style_of(j).0, "series {i} and {j} share a colour");
        }
    }
    // … and no (colour, marker) pair repeats within 60 series.
    let styles: Vec<(RGBColor, usize)> = (0..60).map(style_of).collect();
    for i in 0..60 {
        for j in 0..i {
            assert!(styles[i] != styles[j], "series {i} and {j} look alike");
        }
    }
}

fn one_series_plot(points: Vec<(f64, f64)>) -> XyPlot {
    XyPlot {
        title: "t".into(),
        x_label: "x".into(),
        y_label: "y".into(),
        x_scale: Scale::Log,
        y_scale: Scale::Log,
        series: vec![Series { label: "s".into(), points, line: true, ..Series::default() }],
        ..XyPlot::default()
    }
}

#[test]
fn left_out_points_are_counted_by_reason() {
    let plot = one_series_plot(vec![(1.0, 1.0), (2.0, f64::NAN), (f64::INFINITY, 3.0), (4.0, 0.0), (5.0, -1.0)]);
    let notes = left_out_notes(&plot);
    assert_eq!(notes.len(), 2, "{notes:?}");
    assert!(notes[0].starts_with("2 points are not finite"), "{notes:?}");
    assert!(notes[1].starts_with("2 points are zero or negative"), "{notes:?}");
    assert!(left_out_notes(&one_series_plot(vec![(1.0, 1.0)])).is_empty());
    // On a linear axis zero is a value like any other.
    let linear = XyPlot { y_scale: Scale::Linear, ..one_series_plot(vec![(1.0, 0.0)]) };
    assert!(left_out_notes(&linear).is_empty());
}

#[test]
fn non_finite_points_are_left_out_with_a_note() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.png"), dir.path().join("b.png"));
    draw(&one_series_plot(vec![(1.0, 1.0), (2.0, 3.0)]), &a, 640, 400).unwrap();
    draw(&one_series_plot(vec![(1.0, 1.0), (2.0, 3.0), (3.0, f64::NAN), (4.0, 0.0)]), &b, 640, 400).unwrap();
    // Same axes and points (no line to a fake point); the second image differs only by the note in the
    // legend column.
    let (ia, ib) = (image::open(&a).unwrap().to_rgb8(), image::open(&b).unwrap().to_rgb8());
    let split = 640 - LEGEND_W.min(640 / 3);
    let diff = |x0: u32, x1: u32| {
        (0..400)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .filter(|(x, y)| ia.get_pixel(*x, *y) != ib.get_pixel(*x, *y))
            .count()
    };
    assert_eq!(diff(0, split), 0, "a left-out point changed the chart");
    assert!(diff(split, 640) > 50, "no note about the left-out points");
}

#[test]
fn fronts_compare_only_points_of_one_workload() {
    // Two paths measured on two workloads; path B is faster and worse on "small", dominated on "big".
    let series = |label: &str, pts: Vec<(f64, f64)>| Series {
        label: label.into(),
        points: pts,
        point_workloads: vec!["small".into(), "big".into()],
        ..Series::default()
    };
    let plot = XyPlot {
        series: vec![series("A", vec![(2.0, 1.0), (20.0, 0.5)]), series("B", vec![(1.0, 3.0), (30.0, 4.0)])],
        pareto: true,
        ..XyPlot::default()
    };
    let fronts = workload_fronts(&plot);
    assert_eq!(fronts.len(), 2);
    assert_eq!(fronts[0], ("small".to_string(), vec![(1, 0), (0, 0)]));
    // On "big" A dominates B: a front of one point. Over all points A/small would dominate B/big too,
    // but B/small (x = 1) would sit on one front with A/big; per workload it cannot.
    assert_eq!(fronts[1], ("big".to_string(), vec![(0, 1)]));
    // Left-out points never join a front.
    let c = |pts: Vec<(f64, f64)>| Series {
        label: "C".into(),
        points: pts,
        workload: Some("w".into()),
        ..Series::default()
    };
    let d = Series { label: "D".into(), points: vec![(9.0, 9.0)], workload: Some("w".into()), ..Series::default() };
    let with_nan = XyPlot { series: vec![c(vec![(f64::NAN, 0.1), (5.0, 2.0)]), d.clone()], ..plot.clone() };
    assert_eq!(workload_fronts(&with_nan), vec![("w".to_string(), vec![(0, 1)])]);
    // A workload one series alone measured has no front.
    let alone = XyPlot { series: vec![c(vec![(1.0, 2.0), (2.0, 1.0)])], ..plot.clone() };
    assert!(workload_fronts(&alone).is_empty());
}

#[test]
fn draws_a_png_with_text_and_points() {
    let dir = tempfile::tempdir().unwrap();
    let path =
        std::env::var("METAMER_PLOT_DEMO").map(std::path::PathBuf::from).unwrap_or_else(|_| dir.path().join("p.png"));
    let plot = XyPlot {
        title: "run time against error".into(),
        x_label: "seconds".into(),
        y_label: "mean ΔE00".into(),
        x_scale: Scale::Log,
        y_scale: Scale::Linear,
        y_from_zero: false,
        series: vec![Series {
            label: "a".into(),
            points: vec![(1e-3, 2.0), (1e-2, 1.0), (1e-1, 1.5)],
            spread: Some(vec![(0.8e-3, 1.2e-3), (0.9e-2, 1.1e-2), (0.9e-1, 1.1e-1)]),
            y_spread: Some(vec![(1.8, 2.2), (0.9, 1.1), (1.4, 1.6)]),
            line: true,
            ..Series::default()
        }],
        pareto: true,
        x_refs: vec![(5e-2, "reference".into())],
        notes: vec!["a note".into()],
    };
    draw(&plot, &path, 640, 400).unwrap();
    let img = image::open(&path).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (640, 400));
    // Something other than white was drawn (axes, text, points).
    let dark = img.pixels().filter(|p| p.0.iter().all(|c| *c < 100)).count();
    assert!(dark > 500, "only {dark} dark pixels");
    let empty = XyPlot { series: vec![], x_refs: vec![], ..plot };
    assert!(matches!(draw(&empty, &path, 640, 400), Err(PlotError::Empty)));
}

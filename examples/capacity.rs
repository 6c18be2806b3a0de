//! The capacity protocol (issue 3) across seeds and generator variants:
//!
//! `cargo run --release --example capacity -- [--sizes 10,15] [--seeds 8] [--first-seed 0]
//!  [--start library|flat|random] [--scale luminance|l2|raw] [--refl01] [--time-limit 10] [--per-seed]`
//!
//! For every n it solves `seeds` random n×n palettes one after the other and prints the mean and worst over
//! seeds of the per-palette mean CIELAB ΔE*ab, measured two ways: against the fixed white of linear sRGB
//! (D65, Y = 1: linear sRGB → XYZ → CIELAB, independent of the solved lights' scale) and against the white of
//! each cell's solved light (the reference white of DESIGN_SPEC §1), plus the median and worst solve time.

use metamer::bench::solve::capacity_errors;
use metamer::colorimetry::Colorimetry;
use metamer::design::{self, SolveOptions};
use metamer::palette::random;
use random::{CapacityLightScale, CapacityOptions, CapacityStart};
use std::time::{Duration, Instant};

fn main() -> anyhow::Result<()> {
    let mut sizes: Vec<usize> = (10..=15).collect();
    let mut seeds = 8u64;
    let mut first_seed = 0u64;
    let mut options = CapacityOptions::default();
    let mut time_limit = 10.0;
    let mut per_seed = false;
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    let value = |i: usize| args.get(i + 1).cloned().ok_or_else(|| anyhow::anyhow!("{} needs a value", args[i]));
    while i < args.len() {
        match args[i].as_str() {
            "--sizes" => {
                sizes = value(i)?.split(',').map(|s| s.parse()).collect::<Result<_, _>>()?;
                i += 1;
            }
            "--seeds" => {
                seeds = value(i)?.parse()?;
                i += 1;
            }
            "--first-seed" => {
                first_seed = value(i)?.parse()?;
                i += 1;
            }
            "--time-limit" => {
                time_limit = value(i)?.parse()?;
                i += 1;
            }
            "--start" => {
                options.start = match value(i)?.as_str() {
                    "library" => CapacityStart::Library,
                    "flat" => CapacityStart::Flat,
                    "random" => CapacityStart::Random,
                    s => anyhow::bail!("unknown start {s}"),
                };
                i += 1;
            }
            "--scale" => {
                options.light_scale = match value(i)?.as_str() {
                    "luminance" => CapacityLightScale::Luminance,
                    "l2" => CapacityLightScale::L2,
                    "raw" => CapacityLightScale::Raw,
                    s => anyhow::bail!("unknown scale {s}"),
                };
                i += 1;
            }
            "--refl01" => options.reflectances_below_one = true,
            "--per-seed" => per_seed = true,
            a => anyhow::bail!("unknown argument {a}"),
        }
        i += 1;
    }
    let col = Colorimetry::default();
    let solve_options = SolveOptions { time_limit: Duration::try_from_secs_f64(time_limit)?, cancel: None };
    println!("variant: {options:?}, seeds {first_seed}..{}, time limit {time_limit} s", first_seed + seeds);
    println!("|  n | ΔE*ab sRGB white mean | worst | ΔE*ab light white mean | worst | time median | worst | stopped |");
    println!("|---|---|---|---|---|---|---|---|");
    for &n in &sizes {
        let (mut d65, mut light, mut times, mut stopped) = (Vec::new(), Vec::new(), Vec::new(), 0);
        for seed in first_seed..first_seed + seeds {
            let p = random::capacity_palette_with(n, seed, &col, &options);
            let t = Instant::now();
            let sol = design::solve(&p, None, &col, &solve_options)?;
            let secs = t.elapsed().as_secs_f64();
            let (a, b) = capacity_errors(&p, &sol, &col);
            if sol.diagnostics.iter().any(|d| d.message.contains("stopped early")) {
                stopped += 1;
            }
            if per_seed {
                println!(
                    "  n {n} seed {seed}: ΔE*ab {a:.3} (light white {b:.3}), {secs:.3} s, objective {:.5e}",
                    sol.objective
                );
            }
            d65.push(a);
            light.push(b);
            times.push(secs);
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
        let worst = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut sorted = times.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted.get(sorted.len() / 2).copied().unwrap_or(f64::NAN);
        println!(
            "| {n} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} s | {:.3} s | {stopped} |",
            mean(&d65),
            worst(&d65),
            mean(&light),
            worst(&light),
            median,
            worst(&times)
        );
    }
    Ok(())
}

//! The tests that render the seed's figures and read the public volumes, in their own test binary on
//! [`libtest_mimic`] (`harness = false`), so that a test whose data is missing is reported by the
//! harness as *ignored*, by name, with the reason — not passed. Run with `cargo test --release --test
//! figures` (filters as usual: `-- fig6`).
//!
//! A test marked as needing data runs when the data folder is found (`$METAMER_DATA` or `../shared`,
//! see [`data`]); without it the test is ignored, except under `CI=true` (CI has the data beside its
//! checkout), where it runs and fails with a message naming where the data was looked for. The others
//! (over generated volumes) always run.

use libtest_mimic::{Arguments, Completion, Failed, Trial};
use std::cell::RefCell;

/// A test's measurement lines (`note!` is its `println!`): kept with the test and printed when it fails,
/// or as it runs with `--nocapture` (libtest-mimic captures no output itself).
macro_rules! note {
    ($($arg:tt)*) => { $crate::note(format!($($arg)*)) };
}

mod data;
mod dial_figures;
mod harness;
mod render_accuracy;
mod shared_volumes;

/// Does a test marked as needing data run, or is it ignored (with the reason)?
fn data_gate() -> Result<(), String> {
    let ci = std::env::var("CI").is_ok_and(|v| v == "true");
    if ci || data::shared_dir().is_some() { Ok(()) } else { Err(data::missing()) }
}

/// The trials `module::function` (each a `fn()` that panics on failure), `data` marking those that need
/// the public volumes.
macro_rules! trials {
    ($gate:expr, $echo:expr; $($module:ident :: $test:ident $(, $data:ident)?);* $(;)?) => {
        vec![$(trial(concat!(stringify!($module), "::", stringify!($test)), $module::$test, trials!(@data $($data)?), &$gate, $echo)),*]
    };
    (@data data) => { true };
    (@data) => { false };
}

thread_local! {
    /// The running test's notes, and whether to print them as they come (`--nocapture`).
    static NOTES: RefCell<(String, bool)> = const { RefCell::new((String::new(), false)) };
}

/// Keep (or with `--nocapture` print) one measurement line of the running test.
fn note(line: String) {
    NOTES.with_borrow_mut(|(notes, echo)| {
        if *echo {
            eprintln!("{line}");
        }
        notes.push_str(&line);
        notes.push('\n');
    });
}

fn trial(name: &'static str, test: fn(), needs_data: bool, gate: &Result<(), String>, echo: bool) -> Trial {
    let ignored = if needs_data { gate.clone().err() } else { None };
    Trial::ignorable_test(name, move || {
        if let Some(reason) = ignored {
            return Ok(Completion::ignored_with(reason));
        }
        NOTES.with_borrow_mut(|n| *n = (String::new(), echo));
        let outcome = std::panic::catch_unwind(test);
        let notes = NOTES.with_borrow_mut(|(n, _)| std::mem::take(n));
        match outcome {
            Ok(()) => Ok(Completion::Completed),
            Err(payload) => {
                let why = payload
                    .downcast_ref::<String>()
                    .map(String::as_str)
                    .or_else(|| payload.downcast_ref::<&str>().copied())
                    .unwrap_or("(no message)");
                Err(Failed::from(format!("{notes}panicked: {why}")))
            }
        }
    })
}

fn main() {
    let args = Arguments::from_args();
    let gate = data_gate();
    let trials = trials![gate, args.nocapture;
        dial_figures::fig6a_block_and_inner_are_metamers_the_inner_parts_show_and_the_smoke_vanishes, data;
        dial_figures::fig6b_inner_parts_split_the_block_keeps_its_colour_the_smoke_is_white, data;
        dial_figures::fig6c_block_turns_complementary_inner_keeps_its_b_colour_smoke_vanishes, data;
        dial_figures::fig6d_smoke_glows_red_with_the_purple_light_off_and_the_block_still_green, data;
        dial_figures::fig7a_all_four_tissues_are_metamers, data;
        dial_figures::fig7b_toward_light_2_the_metamers_split_and_the_body_goes_black, data;
        dial_figures::fig7c_a_mixture_of_lights_2_and_3_gives_every_part_its_own_colour, data;
        dial_figures::fig7d_light_1_off_the_body_is_dark_but_slightly_visible, data;
        dial_figures::frog_sweep_daylight_tissues_are_metamers_in_the_frame, data;
        dial_figures::frog_sweep_reveal_and_fluorescent_split_the_tissues, data;
        dial_figures::frames_along_a_constrained_path_keep_the_block_on_target_while_the_smoke_changes;
        render_accuracy::factor_model_tracks_full_spectra_on_the_generated_engine;
        render_accuracy::factor_model_tracks_full_spectra_on_the_shared_engine, data;
        render_accuracy::skips_stay_within_half_a_delta_e_at_p99_on_the_generated_engine;
        render_accuracy::skips_stay_within_half_a_delta_e_at_p99_on_the_shared_engine, data;
        shared_volumes::engine_sweep_factor_mode_tracks_full_mode, data;
        shared_volumes::every_public_volume_reads, data;
        harness::missing_data_is_reported_as_ignored_by_name_and_fails_under_ci;
    ];
    libtest_mimic::run(&args, trials).exit();
}

//! The integration tests in one binary (one link instead of one per file), but for the figures and the public-volume
//! tests, which are `tests/figures/` (their own harness reports missing data as ignored): each former `tests/NAME.rs` is
//! the module `NAME` here, run one with `cargo test --test it NAME::`.

/// An insta snapshot under the top-level `snapshots/` folder, named without its module: the designer's screens
/// (`tui_screens`, `tui_live`, `tui_loop`, `tui_daily`). Defined before the modules, so it is in scope in each.
macro_rules! snap {
    ($name:expr, $text:expr) => {
        insta::with_settings!({ snapshot_path => "../../snapshots", prepend_module_to_snapshot => false }, {
            insta::assert_snapshot!($name, $text);
        })
    };
}

#[allow(dead_code)]
mod common;
#[allow(dead_code)]
mod tui_support;

mod basis_policy;
mod cli_basis;
mod cli_bench;
mod cli_check;
mod cli_design;
mod cli_output;
mod cli_solve;
mod colour_reference;
mod design_cases;
mod design_oracle;
mod dial_design;
mod dial_scene;
mod doc_claims;
mod feasibility;
mod frog_palettes;
mod fuzz_regressions;
mod hostile;
mod palette_file;
mod render_cli;
mod robustness;
mod shading_modes;
mod spec_objective;
mod stress;
mod tui_daily;
mod tui_dial;
mod tui_edits;
mod tui_keyframe_list;
mod tui_live;
mod tui_loop;
mod tui_model;
mod tui_mouse;
mod tui_preview;
mod tui_prompt_memory;
mod tui_region;
mod tui_robust;
mod tui_save;
mod tui_screens;
mod tui_styles;
mod tui_worker;
mod volume_readers;

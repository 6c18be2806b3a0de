//! How long the designer takes from an edit to the redrawn frame, for an 8×8 palette at 100×30 (8 fixed
//! lights, 4 of 8 reflectances designed, 22 colour cells): the UI side alone (update with its undo step,
//! derived colours and ΔE00, draw) and with the re-solve in between, unbounded and with reflectance bounds
//! [0, 1] (L-BFGS-B). The target is one frame, 16 ms.
//!
//! Run: `cargo bench --bench tui_frame`

#[allow(dead_code)]
#[path = "../tests/it/tui_support/mod.rs"]
mod tui_support;

use criterion::{Criterion, criterion_group, criterion_main};
use metamer::design::{self, SolveOptions};
use metamer::palette::Bounds;
use metamer::tui::action::{Action, Direction};
use metamer::tui::app::Focus;
use metamer::tui::colour::ColourMode;
use metamer::tui::msg::Msg;
use metamer::tui::update::update;
use ratatui::Terminal;
use ratatui::backend::TestBackend;
use std::hint::black_box;
use std::sync::Arc;

fn frame(c: &mut Criterion) {
    let mut state = tui_support::state(tui_support::square_palette(8), ColourMode::TrueColor);
    state.ui.focus = Focus::Sliders;
    let mut terminal = Terminal::new(TestBackend::new(100, 30)).expect("test backend");
    c.bench_function("design/edit_and_redraw_8x8", |b| {
        b.iter(|| {
            update(&mut state, Msg::Action(Action::Move(Direction::Right)));
            update(&mut state, Msg::Action(Action::Move(Direction::Left)));
            terminal.draw(|f| f.render_widget(&state, f.area())).expect("draw");
        })
    });
    let options = SolveOptions::default();
    for (label, bounded) in [("resolve_and_redraw_8x8", false), ("resolve_and_redraw_8x8_bounded", true)] {
        let (r, l) = if bounded {
            (Bounds::new(0.0, 1.0), Bounds::new(0.0, f64::INFINITY))
        } else {
            (Bounds::UNBOUNDED, Bounds::UNBOUNDED)
        };
        state.doc.palette.settings.reflectance_bounds = r;
        state.doc.palette.settings.light_bounds = l;
        c.bench_function(&format!("design/{label}"), |b| {
            b.iter(|| {
                update(&mut state, Msg::Action(Action::Move(Direction::Right)));
                let solved = design::solve(
                    &state.doc.palette,
                    state.solve.basis.as_ref().map(|b| b.basis()),
                    &state.colorimetry,
                    &options,
                );
                match solved {
                    Ok(s) => state.solve.solution = Some((state.solve.generation, Arc::new(s))),
                    Err(e) => state.solve.error = Some(e),
                }
                state.refresh();
                terminal.draw(|f| f.render_widget(&state, f.area())).expect("draw");
                black_box(&state.solve.derived);
                update(&mut state, Msg::Action(Action::Move(Direction::Left)));
            })
        });
    }
}

criterion_group!(benches, frame);
criterion_main!(benches);

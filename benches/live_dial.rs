//! Live exploration: one light-dial move in the designer's scene preview — the update (slider step), the
//! relight of the raycast image with the renderer's frame matrix and kernel, the encoding for the
//! terminal (half blocks, or kitty's graphics protocol at real pixels) and the redraw — over the
//! built-in engine scene (the generated 160³ volume of `metamer render`), raycast once beforehand at the
//! panel's pixel size. The target is one frame, 16 ms.
//!
//! Run: `cargo bench --bench live_dial`

#[allow(dead_code)]
#[path = "../tests/it/tui_support/mod.rs"]
mod tui_support;

use criterion::{Criterion, criterion_group, criterion_main};
use metamer::render::builtin_scene;
use metamer::tui::action::Action;
use metamer::tui::colour::ColourMode;
use metamer::tui::graphics::{Graphics, PreviewMode};
use metamer::tui::msg::Msg;
use metamer::tui::preview::{MAX_PREVIEW_EDGE, Preview, cast, preview_model};
use metamer::tui::ui::preview_areas;
use metamer::tui::update::update;
use ratatui::Terminal;
use ratatui::backend::TestBackend;
use ratatui::layout::Rect;
use std::sync::Arc;

fn dial_move(c: &mut Criterion) {
    let scene = Arc::new(builtin_scene(160).expect("built-in scene"));
    let cases = [
        ("halfblocks_100x30", Graphics::halfblocks(), (100, 30)),
        ("halfblocks_200x60", Graphics::halfblocks(), (200, 60)),
        ("kitty_100x30_font8x16", Graphics::forced(PreviewMode::Kitty, (8, 16)), (100, 30)),
        ("kitty_200x60_font8x16", Graphics::forced(PreviewMode::Kitty, (8, 16)), (200, 60)),
    ];
    for (label, graphics, (w, h)) in cases {
        let mut state = tui_support::state(scene.palette.clone(), ColourMode::TrueColor);
        state.preview.graphics = graphics;
        state.set_preview_scene((*scene).clone());
        let areas = preview_areas(&state, Rect::new(0, 0, w, h)).expect("a preview panel");
        let side = state.preview.graphics.pixels_for(areas.image, MAX_PREVIEW_EDGE);
        let preview = Preview::new(
            scene.clone(),
            preview_model(&scene, &state.colorimetry),
            cast(&scene, side, side),
            &state.colorimetry,
        );
        state.set_preview(preview);
        state.preview.keys = true;
        let mut terminal = Terminal::new(TestBackend::new(w, h)).expect("test backend");
        let mut dx = 1;
        c.bench_function(&format!("live/dial_move_{label}_{side}px"), |b| {
            b.iter(|| {
                dx = -dx;
                update(&mut state, Msg::Action(Action::DialSlide { dx, dy: 0, big: false }));
                terminal.draw(|f| f.render_widget(&state, f.area())).expect("draw");
            })
        });
    }
}

criterion_group! { name = benches; config = Criterion::default().sample_size(20); targets = dial_move }
criterion_main!(benches);

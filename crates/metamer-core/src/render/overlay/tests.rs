use super::*;
use crate::render::dial::{DialLight, DialState};

fn dial() -> Dial {
    let mut s = DialState::new(vec![
        DialLight::new("red", Spectrum::flat(1.0), [0.0, 1.0]),
        DialLight::new("green", Spectrum::flat(1.0), [1.0, 0.0]),
        DialLight::new("blue", Spectrum::flat(1.0), [-1.0, 0.0]),
    ])
    .unwrap();
    let k0 = s.clone();
    s.set_on(1, false).unwrap();
    s.set_slider([0.2, 0.3]).unwrap();
    Dial::keyframes(k0.clone(), vec![k0, s]).unwrap()
}

/// A diamond of four lights with names long and short, as in the seed's Fig. 6.
fn diamond() -> Dial {
    let s = DialState::new(vec![
        DialLight::new("glow", Spectrum::flat(1.0), [0.0, 1.0]),
        DialLight::new("split", Spectrum::flat(1.0), [1.0, 0.0]),
        DialLight::new("fluorescent", Spectrum::flat(1.0), [0.0, -1.0]),
        DialLight::new("hide", Spectrum::flat(1.0), [-1.0, 0.0]),
    ])
    .unwrap();
    let mut mid = s.clone();
    mid.set_slider([0.3, 0.2]).unwrap();
    let mut end = s.clone();
    end.set_slider([1.0, 0.0]).unwrap();
    Dial::keyframes(s.clone(), vec![s, mid, end]).unwrap()
}

fn changed(a: &[u8], b: &[u8], w: usize) -> Vec<(usize, usize)> {
    (0..a.len() / 3).filter(|&i| a[i * 3..i * 3 + 3] != b[i * 3..i * 3 + 3]).map(|i| (i % w, i / w)).collect()
}

#[test]
fn draws_only_inside_its_panel_lower_right_by_default_and_deterministically() {
    let (w, h) = (300, 240);
    let d = dial();
    let o = DialOverlay::new(&d, &Colorimetry::default(), w, h);
    assert_eq!(o.corner(), Corner::LowerRight);
    let [x0, y0, pw, ph] = o.panel_rect().expect("a 300×240 frame has a dial");
    assert!(pw as f32 <= MAX_SHARE * w as f32 && ph as f32 <= MAX_SHARE * h as f32, "{pw}×{ph}");
    let blank = vec![90u8; w * h * 3];
    let mut a = blank.clone();
    o.draw_frame(&mut a, w, h, &d, 1, 2);
    let mut b = blank.clone();
    o.draw_frame(&mut b, w, h, &d, 1, 2);
    assert_eq!(a, b);
    let px = changed(&a, &blank, w);
    assert!(px.len() > 500, "{} pixels changed", px.len());
    assert!(px.iter().all(|&(x, y)| (x0..x0 + pw).contains(&x) && (y0..y0 + ph).contains(&y)));
    assert!(x0 >= w / 2 && y0 >= h / 2, "panel at {x0}, {y0}");
    let mut c = blank.clone();
    o.draw_frame(&mut c, w, h, &d, 0, 2);
    assert_ne!(a, c, "another state draws differently");
    // Too small a frame: nothing drawn.
    let mut tiny = vec![0u8; 64 * 64 * 3];
    let o = DialOverlay::new(&d, &Colorimetry::default(), 64, 64);
    o.draw_frame(&mut tiny, 64, 64, &d, 0, 1);
    assert!(tiny.iter().all(|&v| v == 0));
}

#[test]
fn the_panel_is_opaque() {
    let (w, h) = (320, 320);
    let d = diamond();
    let o = DialOverlay::new(&d, &Colorimetry::default(), w, h);
    let [x0, y0, pw, ph] = o.panel_rect().unwrap();
    let mut grey = vec![90u8; w * h * 3];
    let mut noise: Vec<u8> = (0..w * h * 3).map(|i| ((i * 7919) % 251) as u8).collect();
    o.draw_frame(&mut grey, w, h, &d, 1, 3);
    o.draw_frame(&mut noise, w, h, &d, 1, 3);
    // Inside the panel (away from its rounded corners) nothing of the frame shows through.
    let r = (o.geometry.as_ref().unwrap().px as usize) + 2;
    for y in y0 + r..y0 + ph - r {
        for x in x0 + r..x0 + pw - r {
            let i = (y * w + x) * 3;
            assert_eq!(grey[i..i + 3], noise[i..i + 3], "frame shows through at {x}, {y}");
        }
    }
}

#[test]
fn names_stay_inside_the_panel_and_clear_of_their_vertex_and_the_slider() {
    for (w, d) in [(1024, diamond()), (384, diamond()), (200, diamond()), (768, dial())] {
        let o = DialOverlay::new(&d, &Colorimetry::default(), w, w);
        let g = o.geometry.as_ref().unwrap();
        let (pw, ph) = (g.panel.0 as f32, g.panel.1 as f32);
        for k in 0..9 {
            let state = d.frame_state(k, 9);
            for (i, (lx, ly)) in label_positions(g, &state).into_iter().enumerate() {
                let l = &g.labels[i];
                let (lw, lh) = (l.width as f32, l.height as f32);
                let halo = g.halo as f32;
                assert!(
                    lx - halo >= 1.0 && ly - halo >= 1.0 && lx + lw + halo <= pw - 1.0 && ly + lh + halo <= ph - 1.0,
                    "{w}²: name {i} at {lx},{ly} ({lw}×{lh}) outside the {pw}×{ph} panel"
                );
                // The nearest point of the name's box keeps the clearance from its own vertex.
                let (vx, vy) = g.map(state.lights[i].position);
                let nx = vx.clamp(lx, lx + lw);
                let ny = vy.clamp(ly, ly + lh);
                let dist = ((nx - vx).powi(2) + (ny - vy).powi(2)).sqrt();
                assert!(dist >= g.reticle().1, "{w}²: name {i} {dist} px from its vertex");
            }
        }
    }
}

/// The Fig. 6 diamond with the slider swept from the middle onto `hide` and on to `glow`.
fn to_hide() -> Dial {
    let s = diamond().base;
    let mut hide = s.clone();
    hide.set_slider([-1.0, 0.0]).unwrap();
    let mut glow = s.clone();
    glow.set_slider([0.0, 1.0]).unwrap();
    Dial::keyframes(s.clone(), vec![s, hide, glow]).unwrap()
}

#[test]
fn no_name_is_drawn_over_the_slider_at_or_near_a_vertex() {
    let d = to_hide();
    for w in [1024, 384, 200] {
        let o = DialOverlay::new(&d, &Colorimetry::default(), w, w);
        let g = o.geometry.as_ref().unwrap();
        let [x0, y0, _, _] = o.panel_rect().unwrap();
        let mut states: Vec<DialState> = (0..13).map(|k| d.frame_state(k, 13)).collect();
        for p in [[-1.0, 0.0], [-0.95, 0.03], [-0.9, -0.05], [-0.8, 0.1], [-0.05, 0.95]] {
            let mut s = d.base.clone();
            s.set_slider(p).unwrap();
            states.push(s);
        }
        for state in &states {
            // The name's text box with its halo against the box of the reticle's white strokes.
            let (sx, sy) = g.map(state.slider);
            let reach = g.reticle().1 + g.reticle_stroke() / 2.0;
            let marker = [sx - reach, sy - reach, sx + reach, sy + reach];
            let halo = g.halo as f32;
            for (i, (lx, ly)) in label_positions(g, state).into_iter().enumerate() {
                let l = &g.labels[i];
                let (lw, lh) = (l.width as f32, l.height as f32);
                let text = [lx - halo, ly - halo, lx + lw + halo, ly + lh + halo];
                assert_eq!(
                    overlap(text, marker),
                    0.0,
                    "{w}²: slider at {:?}: name {} {text:?} over the slider {marker:?}",
                    state.slider,
                    state.lights[i].name
                );
            }
            // And in the pixels: the reticle's ring is white all round (a name's halo would paint it
            // the panel's colour): the brightest pixel within one of each point on the ring.
            let mut rgb = vec![0u8; w * w * 3];
            o.draw(&mut rgb, w, w, state, &[]);
            let (ring, _) = g.reticle();
            for a in 0..48 {
                let phi = a as f32 * std::f32::consts::TAU / 48.0;
                let (x, y) = (sx + ring * phi.cos(), sy + ring * phi.sin());
                let p = (0..9)
                    .map(|n| {
                        let (px, py) = (x.round() as usize + n % 3 - 1, y.round() as usize + n / 3 - 1);
                        let i = ((y0 + py) * w + x0 + px) * 3;
                        [rgb[i], rgb[i + 1], rgb[i + 2]]
                    })
                    .max_by_key(|p| p.iter().map(|&v| u32::from(v)).sum::<u32>())
                    .unwrap_or_default();
                assert!(p.iter().all(|&v| v > 200), "{w}²: slider at {:?}: ring at {a}/48 is {p:?}", state.slider);
            }
        }
    }
}

#[test]
fn the_slider_is_a_white_hollow_reticle_not_a_disc() {
    // Every light yellow: the slider must still look like none of them.
    let yellow = Spectrum::illuminant("A").unwrap();
    let mut s = DialState::new(vec![
        DialLight::new("a", yellow, [0.0, 1.0]),
        DialLight::new("b", yellow, [1.0, -1.0]),
        DialLight::new("c", yellow, [-1.0, -1.0]),
    ])
    .unwrap();
    s.set_slider([0.0, -0.2]).unwrap();
    let d = Dial::keyframes(s.clone(), vec![s.clone()]).unwrap();
    let (w, h) = (600, 600);
    let o = DialOverlay::new(&d, &Colorimetry::default(), w, h);
    let g = o.geometry.as_ref().unwrap();
    let [x0, y0, _, _] = o.panel_rect().unwrap();
    let mut rgb = vec![0u8; w * h * 3];
    o.draw(&mut rgb, w, h, &s, &[]);
    let at = |(x, y): (f32, f32)| {
        let i = ((y0 + y.round() as usize) * w + x0 + x.round() as usize) * 3;
        [rgb[i], rgb[i + 1], rgb[i + 2]]
    };
    let (sx, sy) = g.map(s.slider);
    let (ring, _) = g.reticle();
    assert_eq!(at((sx, sy)), PANEL, "the reticle is hollow");
    for (dx, dy) in [(ring, 0.0), (-ring, 0.0), (0.0, ring), (0.0, -ring)] {
        let p = at((sx + dx, sy + dy));
        assert!(p.iter().all(|&v| v > 200), "ring at {dx},{dy} is {p:?}");
    }
    let vertex = at(g.map(s.lights[0].position));
    assert!(vertex[2] < vertex[0], "a vertex is a disc in its light's colour: {vertex:?}");
}

#[test]
fn the_emptiest_corner_is_chosen_and_ties_go_lower_right() {
    let (w, h) = (256, 256);
    let d = diamond();
    let mut o = DialOverlay::new(&d, &Colorimetry::default(), w, h);
    let empty = ChannelImage { width: w / 2, height: h / 2, channels: 2, data: vec![0.0; w * h / 2] };
    assert_eq!(o.choose_corner(&empty), Corner::LowerRight);
    // Covered everywhere but the upper left quarter (the image at half the frame's size).
    let mut data = vec![0.0f32; w * h / 2];
    for y in 0..h / 2 {
        for x in 0..w / 2 {
            if x >= w / 4 || y >= h / 4 {
                data[(y * w / 2 + x) * 2] = if (x + y) % 2 == 0 { 0.5 } else { -0.5 };
            }
        }
    }
    let img = ChannelImage { width: w / 2, height: h / 2, channels: 2, data };
    assert_eq!(o.choose_corner(&img), Corner::UpperLeft);
    let [x0, y0, _, _] = o.panel_rect().unwrap();
    assert!(x0 < w / 4 && y0 < h / 4);
    // A tile overlay keeps the corner.
    let tile = o.for_size(200, 200);
    assert_eq!(tile.corner(), Corner::UpperLeft);
    assert!(tile.panel_rect().unwrap()[0] < 100);
}

#[test]
fn light_colour_of_a_white_light_is_white_and_of_a_dark_light_grey() {
    let col = Colorimetry::default();
    let e = Spectrum::illuminant("D65").unwrap();
    let c = light_colour(&col, &e);
    assert!(c.iter().all(|&v| v > 240), "{c:?}");
    assert_eq!(light_colour(&col, &Spectrum::flat(0.0)), [128, 128, 128]);
}

#[test]
fn a_tile_gets_its_own_legible_dial_not_a_shrunk_one() {
    // A 48-frame sweep at 384² has tiles of 228 px: the frame's 10.7 px text shrunk would be 6.3 px;
    // the tile's own layout is limited by the panel's share of the tile (this diamond's four names).
    let d = diamond();
    let frame = DialOverlay::new(&d, &Colorimetry::default(), 384, 384);
    let tile = frame.for_size(228, 228);
    let (fp, tp) = (frame.geometry.as_ref().unwrap().px, tile.geometry.as_ref().unwrap().px);
    assert!(tp >= 7.0 && tp > fp * 228.0 / 384.0 + 1.0, "tile text {tp} px, frame text {fp} px");
    let [_, _, pw, ph] = tile.panel_rect().unwrap();
    assert!(pw as f32 <= MAX_SHARE * 228.0 && ph as f32 <= MAX_SHARE * 228.0, "{pw}×{ph}");
}

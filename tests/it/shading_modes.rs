//! The three `shading` modes of a scene's `[render]` table (docs/formats/scene.md) as rendered: an opaque cube
//! turned about the vertical axis, the shade of its material in the centre pixel (the face the eye sees).
//!
//! The page says: shading = ambient + (1 − ambient)·max(n·l, 0) with n the field's normal turned to face
//! the eye; `headlight` lights from the eye (so the diffuse term is |n·v|), `key` from a fixed light above
//! left of the eye, `unshaded` is 1 everywhere.

use metamer::render::{Camera, MaterialClass, RaycastOptions, Shading, raycast};
use metamer::volume::Volume;
use std::path::Path;

const N: usize = 48;
/// How deep the ramp at the faces is (voxels).
const RAMP: f32 = 3.0;
const AMBIENT: f64 = 0.3;
/// The default camera's elevation (degrees), which these views keep.
const ELEVATION_DEG: f64 = 20.0;

/// A cube (24 voxels wide) whose value ramps from 0 at its faces to 100 [`RAMP`] voxels in: the material covers the ramp (values
/// 10–90), so every sample that carries weight lies in a face's ramp, where the field's normal is the
/// face's. The centre ray crosses the ramp of the face it enters and of the one it leaves: their normals,
/// turned to face the eye, are the same. Unshaded and shaded views take the same samples with the same
/// opacities, so the shaded weight over the unshaded weight is the shade itself. Up to 30° of azimuth the
/// centre ray stays more than a ramp's depth from the face's edges (at 40° it crosses the next face's ramp).
fn cube() -> Volume {
    let (lo, hi) = (N / 4, 3 * N / 4);
    let depth = |v: usize| if (lo..hi).contains(&v) { (v + 1 - lo).min(hi - v) as f32 } else { 0.0 };
    let mut data = vec![0f32; N * N * N];
    for z in 0..N {
        for y in 0..N {
            for x in 0..N {
                let d = depth(x).min(depth(y)).min(depth(z));
                data[x + N * (y + N * z)] = 100.0 * (d / RAMP).min(1.0);
            }
        }
    }
    Volume::new(Path::new("ramped cube"), [N; 3], [1.0; 3], data).expect("a valid grid")
}

/// The material's weight in the centre pixel, the cube turned by `azimuth_deg`.
fn centre(vol: &Volume, shading: Shading, ambient: f64, azimuth_deg: f64) -> f64 {
    let mats = [MaterialClass::new([10.0, 90.0], 0.3)];
    let opts = RaycastOptions { width: 65, height: 65, shading, ambient, jitter: false, ..Default::default() };
    let mut cam = Camera::default();
    cam.azimuth_deg = azimuth_deg;
    let (w, _) = raycast(vol, &mats, None, &cam, &opts);
    f64::from(w.data[(w.height / 2) * w.width + w.width / 2])
}

/// The shade of the centre pixel: its weight shaded over its weight unshaded.
fn shade(vol: &Volume, shading: Shading, ambient: f64, azimuth_deg: f64) -> f64 {
    centre(vol, shading, ambient, azimuth_deg) / centre(vol, Shading::Unshaded, ambient, azimuth_deg)
}

/// n·l for the key light of scene.md (eye + 0.55·up − 0.45·right in the camera's frame, normalised) and the
/// −y face, the camera at `azimuth_deg` and the default elevation.
fn key_n_dot_l(azimuth_deg: f64) -> f64 {
    let (az, el) = (azimuth_deg.to_radians(), ELEVATION_DEG.to_radians());
    let eye = [az.sin() * el.cos(), -az.cos() * el.cos(), el.sin()];
    // The camera's right is horizontal, its up completes the frame with the view direction −eye.
    let right = [az.cos(), az.sin(), 0.0];
    let view = eye.map(|c| -c);
    let up = [
        right[1] * view[2] - right[2] * view[1],
        right[2] * view[0] - right[0] * view[2],
        right[0] * view[1] - right[1] * view[0],
    ];
    let l = [0, 1, 2].map(|a| eye[a] + 0.55 * up[a] - 0.45 * right[a]);
    let norm = l.iter().map(|c| c * c).sum::<f64>().sqrt();
    -l[1] / norm
}

#[test]
fn unshaded_is_one_everywhere_headlight_is_n_dot_v_and_key_lights_from_the_left() {
    let vol = cube();
    for az in [-30.0, -15.0, 0.0, 15.0, 30.0] {
        // The centre ray enters the face whose normal is −y; the eye is at (sin az cos el, −cos az cos el,
        // sin el), so n·v = cos az · cos el.
        let n_dot_v = f64::to_radians(az).cos() * ELEVATION_DEG.to_radians().cos();
        let unshaded = centre(&vol, Shading::Unshaded, AMBIENT, az);
        let head = shade(&vol, Shading::Headlight, AMBIENT, az);
        let key = shade(&vol, Shading::Key, AMBIENT, az);
        let expected = AMBIENT + (1.0 - AMBIENT) * n_dot_v;
        let expected_key = AMBIENT + (1.0 - AMBIENT) * key_n_dot_l(az).max(0.0);
        println!(
            "azimuth {az:>5}: unshaded weight {unshaded:.4}; shade: headlight {head:.4} (ambient + (1 − ambient)|n·v| \
             = {expected:.4}), key {key:.4} (expected {expected_key:.4})"
        );
        assert!(unshaded > 0.5, "the ramp must carry weight at {az}°: {unshaded}");
        assert!((head - expected).abs() < 0.003, "headlight at {az}°: shade {head} vs {expected}");
        assert!((key - expected_key).abs() < 0.003, "key at {az}°: shade {key} vs {expected_key}");
        // Ambient 1 leaves no diffuse term: every mode is the unshaded frame.
        for shading in [Shading::Headlight, Shading::Key] {
            let flat = shade(&vol, shading, 1.0, az);
            assert!((flat - 1.0).abs() < 1e-5, "{shading:?} with ambient 1 at {az}°: shade {flat}");
        }
    }
    // The headlight is symmetric about the view; the key light sits to the left of the eye, so the face
    // turned left (positive azimuth turns the −y face's normal against the camera's right) is the brighter.
    for az in [15.0, 30.0] {
        let (l, r) = (shade(&vol, Shading::Headlight, AMBIENT, az), shade(&vol, Shading::Headlight, AMBIENT, -az));
        assert!((l - r).abs() < 0.005, "headlight ±{az}°: {l} vs {r}");
        let (l, r) = (shade(&vol, Shading::Key, AMBIENT, az), shade(&vol, Shading::Key, AMBIENT, -az));
        assert!(l > r + 0.1, "key ±{az}°: the left-turned face {l} should be brighter than {r}");
    }
    // Face-on the headlight is the brighter, the key light being off the view axis.
    let (head, key) = (shade(&vol, Shading::Headlight, AMBIENT, 0.0), shade(&vol, Shading::Key, AMBIENT, 0.0));
    assert!(key < head - 0.02, "face-on: key {key} vs headlight {head}");
}

//! The light dial of seed §5.1: lights are vertices placed in 2D, a slider point moves among them, and
//! the light in use is a weighting of the vertices by the slider's position. Lights can be switched off
//! and their vertices moved; a scene's sweep visits keyframes (or, as before, a path of lights).
//!
//! # The weighting (Shepard inverse-distance weights, exponent [`SHEPARD_EXPONENT`] = 2)
//!
//! For the slider point `p` and the vertices `v_i` of the lights that are **on**,
//!
//! ```text
//! u_i = 1 / |p − v_i|²        w_i = u_i / Σ_j u_j        (lights that are off: w_i = 0)
//! E(p) = Σ_i w_i · a_i · E_i                              (a_i = the light's intensity, default 1)
//! ```
//!
//! The weights of the lights that are on sum to 1; at a light's vertex that light alone has weight 1
//! (lights sharing that vertex share it equally); every other light that is on keeps a small positive
//! weight that falls off with the square of its distance, so a far light still contributes a little
//! (seed Fig. 7(d)). With every light off the weights are all 0 and the light is black.
//!
//! # Sweeps
//!
//! - [`Sweep::Path`] (a scene's `path = [names]`, unchanged from before): frame k of N sits at
//!   `t = k/(N−1)` along the path and mixes the two neighbouring lights linearly (no Shepard weights);
//!   the slider is drawn on the segment between their vertices.
//! - [`Sweep::Keyframes`]: each keyframe is a full dial state (slider point, vertex positions, lights on
//!   or off), the changes a keyframe makes holding from that keyframe on. Frames move the slider along
//!   the polyline through the keyframes' slider points at constant speed (by arc length: frame k of N at
//!   `t = k/(N−1)` of the total length); a frame between keyframes j and j+1 uses keyframe j's lights,
//!   the last frame keyframe N−1's. When every keyframe has the same slider point (no length), frames are
//!   spread evenly over the keyframes instead. [`Timing::PerKeyframe`] spreads frames evenly over the
//!   keyframes whatever the lengths, so N = the number of keyframes renders exactly the keyframes.

use crate::spectrum::Spectrum;

/// The exponent of the Shepard inverse-distance weights: `u_i = 1/d_i^SHEPARD_EXPONENT`.
pub(crate) const SHEPARD_EXPONENT: f64 = 2.0;

/// The largest dial coordinate accepted (either axis, for vertices, moves, keyframe points and a palette's
/// mixture positions): the Shepard weights divide by squared distances, which overflow to infinity from
/// about 1e154 (and every weight is then 0: black frames). Dials are drawn around the unit circle; ±1e6
/// leaves room.
pub(crate) const MAX_DIAL_COORDINATE: f64 = 1e6;

/// Distances below this (in dial units) count as "at the vertex".
const AT_VERTEX: f64 = 1e-9;

/// Why a dial operation was refused.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DialError {
    /// A dial was asked for with no lights.
    #[error("the dial needs at least one light")]
    NoLights,
    /// A light index past the end of the dial's lights.
    #[error("light {index} does not exist (the dial has {count} lights)")]
    NoSuchLight {
        /// The index asked for.
        index: usize,
        /// How many lights the dial has.
        count: usize,
    },
    /// A position (a vertex, the slider or a keyframe) with a coordinate that is not a finite number.
    #[error("{what}: [{x}, {y}] is not a pair of finite numbers")]
    NotFinite {
        /// What the position is, as the message names it: "slider", or "light `NAME` vertex" for a
        /// light's vertex.
        what: String,
        /// Its x coordinate in dial units.
        x: f64,
        /// Its y coordinate in dial units.
        y: f64,
    },
    /// A light's intensity factor that is negative or not finite.
    #[error("light `{name}`: intensity {value} is not a finite number ≥ 0")]
    BadIntensity {
        /// The light's name.
        name: String,
        /// The refused factor.
        value: f64,
    },
}

/// One light of the dial: its spectrum, its vertex, on or off, and an intensity factor.
#[derive(Clone, Debug, PartialEq)]
pub struct DialLight {
    /// The light's name in the palette or scene.
    pub name: String,
    /// Its spectrum on the 31-sample grid, before the intensity factor.
    pub spectrum: Spectrum,
    /// The vertex in dial coordinates (the palette's `dial = [x, y]`, or a default on a unit circle).
    pub position: [f64; 2],
    /// Whether the light is switched on (an off light weighs nothing in the mixture).
    pub on: bool,
    /// Multiplies the light's spectrum (1 = as in the palette).
    pub intensity: f64,
}

impl DialLight {
    /// A light that is on, with intensity 1.
    pub fn new(name: impl Into<String>, spectrum: Spectrum, position: [f64; 2]) -> DialLight {
        DialLight { name: name.into(), spectrum, position, on: true, intensity: 1.0 }
    }
}

fn check_point(what: &str, p: [f64; 2]) -> Result<(), DialError> {
    if p[0].is_finite() && p[1].is_finite() {
        Ok(())
    } else {
        Err(DialError::NotFinite { what: what.to_string(), x: p[0], y: p[1] })
    }
}

/// Default vertex `i` of `n` for lights without a `dial` position: a regular polygon on the unit circle,
/// starting at the top and going clockwise.
pub fn default_position(i: usize, n: usize) -> [f64; 2] {
    if n <= 1 {
        return [0.0, 0.0];
    }
    let a = std::f64::consts::FRAC_PI_2 - std::f64::consts::TAU * i as f64 / n as f64;
    [a.cos(), a.sin()]
}

/// The dial at one moment: lights (vertex, on/off, intensity) and the slider point. This is what a
/// frame is lit by and what the overlay draws; a terminal widget can drive it directly.
#[derive(Clone, Debug, PartialEq)]
pub struct DialState {
    /// The dial's lights (a scene's: every light of its palette, in palette order); an index into this list
    /// names a light everywhere on the dial (weights, `Sweep::Path`, toggles).
    pub lights: Vec<DialLight>,
    /// The slider point in dial coordinates; the Shepard weights are taken here.
    pub slider: [f64; 2],
    /// Weights for [`Sweep::Path`] frames (linear mix of two neighbours) instead of Shepard weights.
    pub fixed_weights: Option<Vec<f64>>,
}

impl DialState {
    /// A dial over at least one light with finite vertices; the slider starts at the first light's vertex.
    pub fn new(lights: Vec<DialLight>) -> Result<DialState, DialError> {
        let first = lights.first().ok_or(DialError::NoLights)?.position;
        for l in &lights {
            check_point(&format!("light `{}` vertex", l.name), l.position)?;
            if !(l.intensity.is_finite() && l.intensity >= 0.0) {
                return Err(DialError::BadIntensity { name: l.name.clone(), value: l.intensity });
            }
        }
        Ok(DialState { lights, slider: first, fixed_weights: None })
    }

    fn check_index(&self, i: usize) -> Result<(), DialError> {
        if i < self.lights.len() { Ok(()) } else { Err(DialError::NoSuchLight { index: i, count: self.lights.len() }) }
    }

    /// The index of the light called `name`.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.lights.iter().position(|l| l.name == name)
    }

    /// Move the slider point (any finite point; it need not lie inside the vertices' hull).
    pub fn set_slider(&mut self, p: [f64; 2]) -> Result<(), DialError> {
        check_point("slider", p)?;
        self.slider = p;
        self.fixed_weights = None;
        Ok(())
    }

    /// Switch light `i` on or off; returns its new state.
    pub fn toggle(&mut self, i: usize) -> Result<bool, DialError> {
        self.check_index(i)?;
        self.lights[i].on = !self.lights[i].on;
        self.fixed_weights = None;
        Ok(self.lights[i].on)
    }

    /// Switch light `i` on (`true`) or off.
    pub fn set_on(&mut self, i: usize, on: bool) -> Result<(), DialError> {
        self.check_index(i)?;
        self.lights[i].on = on;
        self.fixed_weights = None;
        Ok(())
    }

    /// Set light `i`'s intensity factor (finite, ≥ 0).
    pub fn set_intensity(&mut self, i: usize, value: f64) -> Result<(), DialError> {
        self.check_index(i)?;
        if !(value.is_finite() && value >= 0.0) {
            return Err(DialError::BadIntensity { name: self.lights[i].name.clone(), value });
        }
        self.lights[i].intensity = value;
        Ok(())
    }

    /// Move light `i`'s vertex.
    pub fn move_vertex(&mut self, i: usize, p: [f64; 2]) -> Result<(), DialError> {
        self.check_index(i)?;
        check_point(&format!("light `{}` vertex", self.lights[i].name), p)?;
        self.lights[i].position = p;
        self.fixed_weights = None;
        Ok(())
    }

    /// The weight of every light at the slider (see the module docs; they sum to 1 over the lights that
    /// are on, or are all 0 when every light is off).
    pub fn weights(&self) -> Vec<f64> {
        match &self.fixed_weights {
            Some(w) => w.clone(),
            None => self.weights_at(self.slider),
        }
    }

    /// The Shepard weights of every light at point `p`.
    pub(crate) fn weights_at(&self, p: [f64; 2]) -> Vec<f64> {
        let n = self.lights.len();
        let dist = |l: &DialLight| ((p[0] - l.position[0]).powi(2) + (p[1] - l.position[1]).powi(2)).sqrt();
        let at: Vec<bool> = self.lights.iter().map(|l| l.on && dist(l) < AT_VERTEX).collect();
        let hits = at.iter().filter(|&&a| a).count();
        if hits > 0 {
            return at.iter().map(|&a| if a { 1.0 / hits as f64 } else { 0.0 }).collect();
        }
        let u: Vec<f64> =
            self.lights.iter().map(|l| if l.on { dist(l).powf(-SHEPARD_EXPONENT) } else { 0.0 }).collect();
        let sum: f64 = u.iter().sum();
        if sum > 0.0 && sum.is_finite() { u.iter().map(|x| x / sum).collect() } else { vec![0.0; n] }
    }

    /// The light at the slider: Σ wᵢ · intensityᵢ · Eᵢ.
    pub fn light(&self) -> Spectrum {
        self.mix(&self.weights())
    }

    /// The light the dial would give with the slider at `p`.
    pub fn light_at(&self, p: [f64; 2]) -> Spectrum {
        self.mix(&self.weights_at(p))
    }

    fn mix(&self, w: &[f64]) -> Spectrum {
        let mut s = Spectrum::flat(0.0);
        for (l, &wi) in self.lights.iter().zip(w) {
            if wi != 0.0 {
                s.0 += l.spectrum.0 * (wi * l.intensity);
            }
        }
        s
    }

    /// The smallest box `[[x0, y0], [x1, y1]]` holding every vertex and the slider.
    pub fn bounds(&self) -> [[f64; 2]; 2] {
        let mut b = [self.slider, self.slider];
        for l in &self.lights {
            b[0] = [b[0][0].min(l.position[0]), b[0][1].min(l.position[1])];
            b[1] = [b[1][0].max(l.position[0]), b[1][1].max(l.position[1])];
        }
        b
    }
}

/// How frames are spread over keyframes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Timing {
    /// Constant slider speed by arc length (the default).
    #[default]
    ConstantSpeed,
    /// Evenly over the keyframes: frame k of N is keyframe k when N = the number of keyframes.
    PerKeyframe,
}

/// What a sweep of frames does with the dial.
#[derive(Clone, Debug, PartialEq)]
pub enum Sweep {
    /// Visit these lights (indices into the dial's lights) in order, mixing neighbours linearly.
    Path(Vec<usize>),
    /// Move through these states (at least one).
    Keyframes(Vec<DialState>),
}

/// A scene's light dial: its lights and the sweep its frames follow.
#[derive(Clone, Debug, PartialEq)]
pub struct Dial {
    /// The dial at rest: every light with its vertex, on/off and intensity; the slider at the start.
    pub base: DialState,
    /// What the frames do with the dial: a path of lights or keyframes.
    pub sweep: Sweep,
    /// How the frames are spread over the keyframes (by arc length, or evenly per keyframe).
    pub timing: Timing,
}

fn lerp(a: [f64; 2], b: [f64; 2], f: f64) -> [f64; 2] {
    [a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f]
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

impl Dial {
    /// A dial visiting `path` (indices into `base.lights`, at least one, each valid).
    pub fn path(base: DialState, path: Vec<usize>) -> Result<Dial, DialError> {
        if path.is_empty() {
            return Err(DialError::NoLights);
        }
        for &i in &path {
            base.check_index(i)?;
        }
        let mut dial = Dial { base, sweep: Sweep::Path(path), timing: Timing::ConstantSpeed };
        dial.base = dial.state_at(0.0);
        Ok(dial)
    }

    /// A dial moving through `keyframes` (at least one; each over the same lights as `base`).
    pub(crate) fn keyframes(base: DialState, keyframes: Vec<DialState>) -> Result<Dial, DialError> {
        if keyframes.is_empty() {
            return Err(DialError::NoLights);
        }
        Ok(Dial { base, sweep: Sweep::Keyframes(keyframes), timing: Timing::ConstantSpeed })
    }

    /// Position of frame `k` of `n` along the sweep, in [0, 1] (`k/(n−1)`, 0 for a single frame).
    pub(crate) fn position(k: usize, n: usize) -> f64 {
        if n <= 1 { 0.0 } else { (k as f64 / (n - 1) as f64).clamp(0.0, 1.0) }
    }

    /// The number of keyframes (path: the lights visited).
    pub fn keyframe_count(&self) -> usize {
        match &self.sweep {
            Sweep::Path(p) => p.len(),
            Sweep::Keyframes(k) => k.len(),
        }
    }

    /// The stages of the sweep in order, as a person reads them: path: the lights visited; keyframes:
    /// each keyframe's slider as the light whose vertex it sits on (else its point `[0.70, 0.90]`),
    /// followed by the lights off there (`[0.70, 0.90] (purple off)`). Names are not escaped.
    pub fn stages(&self) -> Vec<String> {
        match &self.sweep {
            Sweep::Path(p) => p.iter().map(|&i| self.base.lights[i].name.clone()).collect(),
            Sweep::Keyframes(k) => k
                .iter()
                .map(|s| {
                    let at = s
                        .lights
                        .iter()
                        .find(|l| dist(l.position, s.slider) < 1e-9)
                        .map_or_else(|| format!("[{:.2}, {:.2}]", s.slider[0], s.slider[1]), |l| l.name.clone());
                    let off: Vec<&str> = s.lights.iter().filter(|l| !l.on).map(|l| l.name.as_str()).collect();
                    if off.is_empty() { at } else { format!("{at} ({} off)", off.join(", ")) }
                })
                .collect(),
        }
    }

    /// Keyframe segment and fraction at `t` in [0, 1].
    fn locate(&self, t: f64, points: &[[f64; 2]]) -> (usize, f64) {
        let n = points.len();
        if n <= 1 {
            return (0, 0.0);
        }
        let t = t.clamp(0.0, 1.0);
        let lens: Vec<f64> = points.windows(2).map(|w| dist(w[0], w[1])).collect();
        let total: f64 = lens.iter().sum();
        let even = |t: f64| {
            let u = t * (n - 1) as f64;
            let i = (u.floor() as usize).min(n - 2);
            (i, u - i as f64)
        };
        if self.timing == Timing::PerKeyframe
            || total.is_nan()
            || total <= 1e-12
            || matches!(self.sweep, Sweep::Path(_))
        {
            let (i, f) = even(t);
            return if f >= 1.0 - 1e-12 { (i + 1, 0.0) } else { (i, f) };
        }
        let s = t * total;
        let mut acc = 0.0;
        for (i, &len) in lens.iter().enumerate() {
            if s < acc + len && len > 0.0 {
                return (i, (s - acc) / len);
            }
            acc += len;
        }
        (n - 1, 0.0)
    }

    fn path_points(&self) -> Vec<[f64; 2]> {
        match &self.sweep {
            Sweep::Path(p) => p.iter().map(|&i| self.base.lights[i].position).collect(),
            Sweep::Keyframes(k) => k.iter().map(|s| s.slider).collect(),
        }
    }

    /// The dial's state at `t` in [0, 1] along the sweep (see the module docs).
    pub fn state_at(&self, t: f64) -> DialState {
        let points = self.path_points();
        if points.is_empty() {
            return self.base.clone();
        }
        let (i, f) = self.locate(t, &points);
        match &self.sweep {
            Sweep::Path(path) => {
                let mut s = self.base.clone();
                let mut w = vec![0.0; s.lights.len()];
                w[path[i]] += 1.0 - f;
                if f > 0.0 {
                    w[path[i + 1]] += f;
                }
                s.slider = if f > 0.0 { lerp(points[i], points[i + 1], f) } else { points[i] };
                s.fixed_weights = Some(w);
                s
            }
            Sweep::Keyframes(k) => {
                let mut s = k[i].clone();
                if f > 0.0 {
                    s.slider = lerp(points[i], points[i + 1], f);
                }
                s
            }
        }
    }

    /// The state of frame `k` of `n`.
    pub fn frame_state(&self, k: usize, n: usize) -> DialState {
        self.state_at(Dial::position(k, n))
    }

    /// The light at `t` in [0, 1] along the sweep.
    pub fn light_at(&self, t: f64) -> Spectrum {
        self.state_at(t).light()
    }

    /// The slider's trail from the start of the sweep to `t`: the keyframe (or path vertex) points passed
    /// and the slider's point at `t`, in order.
    pub fn trail(&self, t: f64) -> Vec<[f64; 2]> {
        let points = self.path_points();
        if points.is_empty() {
            return Vec::new();
        }
        let (i, f) = self.locate(t, &points);
        let mut trail: Vec<[f64; 2]> = points[..=i.min(points.len() - 1)].to_vec();
        if f > 0.0 && i + 1 < points.len() {
            trail.push(lerp(points[i], points[i + 1], f));
        }
        trail
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lights() -> Vec<DialLight> {
        vec![
            DialLight::new("a", Spectrum::flat(1.0), [0.0, 0.0]),
            DialLight::new("b", Spectrum::flat(2.0), [1.0, 0.0]),
            DialLight::new("c", Spectrum::flat(4.0), [0.0, 1.0]),
        ]
    }

    fn state() -> DialState {
        DialState::new(lights()).unwrap()
    }

    #[test]
    fn stages_follow_the_keyframes_in_their_order_with_the_lights_off() {
        let mut k: Vec<DialState> =
            [2, 0, 1].iter().map(|&i| DialState { slider: lights()[i].position, ..state() }).collect();
        let mut between = state();
        between.slider = [0.25, 0.5];
        between.set_on(2, false).unwrap();
        k.push(between);
        let d = Dial::keyframes(state(), k).unwrap();
        assert_eq!(d.stages(), ["c", "a", "b", "[0.25, 0.50] (c off)"]);
        assert_eq!(Dial::path(state(), vec![1, 2, 0]).unwrap().stages(), ["b", "c", "a"]);
    }

    #[test]
    fn path_frames_walk_the_path_and_mix_neighbours_as_before() {
        let d = Dial::path(state(), vec![0, 1, 2]).unwrap();
        assert_eq!(Dial::position(0, 5), 0.0);
        assert_eq!(Dial::position(4, 5), 1.0);
        assert_eq!(Dial::position(0, 1), 0.0);
        assert_eq!(d.light_at(0.0).0[0], 1.0);
        assert_eq!(d.light_at(0.5).0[0], 2.0);
        assert_eq!(d.light_at(1.0).0[0], 4.0);
        assert!((d.light_at(0.25).0[0] - 1.5).abs() < 1e-12);
        assert!((d.light_at(0.75).0[0] - 3.0).abs() < 1e-12);
        let w = d.state_at(0.6).weights();
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12 && w[0] == 0.0);
        // The slider is drawn between the two neighbours' vertices.
        let s = d.state_at(0.25).slider;
        assert!((s[0] - 0.5).abs() < 1e-12 && s[1].abs() < 1e-12);
        assert!(Dial::path(state(), vec![]).is_err());
        assert!(Dial::path(state(), vec![3]).is_err());
    }

    #[test]
    fn shepard_weights_are_exact_at_vertices_and_positive_elsewhere() {
        let mut s = state();
        for i in 0..3 {
            let w = s.weights_at(s.lights[i].position);
            for (j, wj) in w.iter().enumerate() {
                assert_eq!(*wj, if i == j { 1.0 } else { 0.0 });
            }
        }
        s.set_slider([0.5, 0.5]).unwrap();
        let w = s.weights();
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        // Distances √0.5 to all three: equal weights.
        assert!(w.iter().all(|x| (x - 1.0 / 3.0).abs() < 1e-12), "{w:?}");
        // Exponent 2: at (0.1, 0) the distances are 0.1, 0.9, √1.01.
        s.set_slider([0.1, 0.0]).unwrap();
        let w = s.weights();
        let u = [1.0 / 0.01, 1.0 / 0.81, 1.0 / 1.01];
        let sum: f64 = u.iter().sum();
        for (wi, ui) in w.iter().zip(u) {
            assert!((wi - ui / sum).abs() < 1e-12);
        }
        // A far light still contributes a little.
        assert!(w[2] > 0.005 && w[2] < 0.02, "{w:?}");
        let e = s.light().0[0];
        assert!((e - (w[0] + 2.0 * w[1] + 4.0 * w[2])).abs() < 1e-12);
    }

    #[test]
    fn lights_off_get_no_weight_and_intensity_scales_the_light() {
        let mut s = state();
        s.set_slider([0.0, 0.0]).unwrap();
        assert_eq!(s.toggle(0), Ok(false));
        let w = s.weights();
        assert_eq!(w[0], 0.0);
        // Off at its own vertex: the others share by distance (both at 1).
        assert!((w[1] - 0.5).abs() < 1e-12 && (w[2] - 0.5).abs() < 1e-12);
        assert!((s.light().0[0] - 3.0).abs() < 1e-12);
        s.set_intensity(1, 0.5).unwrap();
        assert!((s.light().0[0] - (0.5 + 2.0)).abs() < 1e-12);
        s.set_on(1, false).unwrap();
        s.set_on(2, false).unwrap();
        assert!(s.weights().iter().all(|&x| x == 0.0));
        assert_eq!(s.light().0[0], 0.0);
        assert!(s.toggle(7).is_err());
        assert!(s.set_intensity(0, f64::NAN).is_err());
        assert!(s.set_slider([f64::NAN, 0.0]).is_err());
        assert!(s.move_vertex(0, [0.0, f64::INFINITY]).is_err());
        assert!(DialState::new(vec![]).is_err());
    }

    #[test]
    fn moving_a_vertex_moves_its_influence() {
        let mut s = state();
        s.set_slider([0.9, 0.0]).unwrap();
        let before = s.weights()[2];
        s.move_vertex(2, [0.9, 0.1]).unwrap();
        assert!(s.weights()[2] > before);
        assert_eq!(s.index("c"), Some(2));
        assert_eq!(s.index("z"), None);
        assert_eq!(s.bounds(), [[0.0, 0.0], [1.0, 0.1]]);
    }

    #[test]
    fn keyframes_move_at_constant_speed_and_changes_hold_from_their_keyframe_on() {
        let base = state();
        let mut k0 = base.clone();
        k0.set_slider([0.0, 0.0]).unwrap();
        let mut k1 = k0.clone();
        k1.set_slider([3.0, 0.0]).unwrap();
        k1.set_on(0, false).unwrap();
        let mut k2 = k1.clone();
        k2.set_slider([3.0, 1.0]).unwrap();
        let d = Dial::keyframes(base, vec![k0, k1, k2]).unwrap();
        // Total length 4: t = 0.5 is at x = 2 on the first segment, still with keyframe 0's lights.
        let s = d.state_at(0.5);
        assert!((s.slider[0] - 2.0).abs() < 1e-12 && s.slider[1] == 0.0);
        assert!(s.lights[0].on);
        // t = 0.75 is keyframe 1 exactly: light a is off from here on.
        let s = d.state_at(0.75);
        assert!((s.slider[0] - 3.0).abs() < 1e-12 && !s.lights[0].on);
        let s = d.state_at(0.875);
        assert!((s.slider[1] - 0.5).abs() < 1e-12 && !s.lights[0].on);
        assert_eq!(d.state_at(1.0).slider, [3.0, 1.0]);
        // Equal slider steps between equally spaced frames.
        let xs: Vec<f64> = (0..5).map(|k| d.frame_state(k, 9).slider[0]).collect();
        for w in xs.windows(2) {
            assert!((w[1] - w[0] - 0.5).abs() < 1e-12, "{xs:?}");
        }
        let trail = d.trail(0.875);
        assert_eq!(trail.len(), 3);
        assert_eq!(trail[1], [3.0, 0.0]);
        // Per keyframe: N = 3 frames are exactly the keyframes.
        let mut per = d.clone();
        per.timing = Timing::PerKeyframe;
        assert_eq!(per.frame_state(1, 3).slider, [3.0, 0.0]);
        assert!(!per.frame_state(1, 3).lights[0].on);
        assert_eq!(per.frame_state(2, 3).slider, [3.0, 1.0]);
        assert_eq!(per.keyframe_count(), 3);
    }

    #[test]
    fn keyframes_at_one_point_spread_frames_evenly() {
        let base = state();
        let mut k1 = base.clone();
        k1.set_on(0, false).unwrap();
        let d = Dial::keyframes(base.clone(), vec![base, k1]).unwrap();
        assert!(d.state_at(0.0).lights[0].on);
        assert!(d.state_at(0.4).lights[0].on);
        assert!(!d.state_at(1.0).lights[0].on);
    }

    #[test]
    fn default_positions_are_a_regular_polygon() {
        assert_eq!(default_position(0, 1), [0.0, 0.0]);
        let p = default_position(0, 4);
        assert!(p[0].abs() < 1e-12 && (p[1] - 1.0).abs() < 1e-12);
        let q = default_position(1, 4);
        assert!((q[0] - 1.0).abs() < 1e-12 && q[1].abs() < 1e-12);
    }
}

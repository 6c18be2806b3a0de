//! Seeded random palettes for tests and benchmarks (deterministic: the same seed gives the same palette).
//!
//! * [`capacity_palette`]: the TOG 2009 Fig. 3 protocol — n lights × n reflectances, all designed, every
//!   cell a uniform random linear-RGB target, positivity bounds, smoothness 0.001;
//! * [`batch_palette`]: many independent designed reflectances under 3 fixed lights with `[0, 1]` bounds
//!   (targets perturbed, most designs press on the bounds); [`reachable_batch_palette`]: the same with every
//!   target the colour of a reflectance in the bounds;
//! * [`convex_palette`]: random mixes of designed lights or reflectances (never both in one cell), free
//!   groups, weights across decades and bounds, for checking optimality against an independent solver.
//!
//! Generated workloads, as `volume::generate` generates volumes: `metamer bench`, the benchmarks in
//! `benches/`, the examples (`batch_palette`, `capacity`) and the tests all draw their palettes from here.
use crate::colorimetry::Colorimetry;
use crate::palette::{Bounds, ColourCell, FreeGroup, Kind, Palette, Settings, Source, SpectrumEntry, TargetNotation};
use crate::spectrum::{Normalize, SAMPLES, Spectrum};
use nalgebra::Vector3;

pub use crate::optimize::Rng;

/// A smooth random spectrum in [0, 1]: a constant plus three Gaussian bumps, clipped.
pub fn smooth_spectrum(rng: &mut Rng) -> Spectrum {
    let mut s = [rng.range(0.0, 0.3); SAMPLES];
    for _ in 0..3 {
        let (c, w, h) = (rng.range(-5.0, 35.0), rng.range(3.0, 10.0), rng.range(-0.3, 0.9));
        for (i, v) in s.iter_mut().enumerate() {
            *v += h * (-((i as f64 - c) / w).powi(2)).exp();
        }
    }
    Spectrum::from_array(s.map(|v| v.clamp(0.0, 1.0)))
}

/// An entry with resolved samples.
pub fn entry(name: &str, kind: Kind, spectrum: Spectrum, design: bool) -> SpectrumEntry {
    SpectrumEntry {
        design,
        ..SpectrumEntry::resolved(name, kind, Source::Samples(spectrum.to_vec()), Normalize::None, spectrum)
    }
}

/// A light normalised to luminance 1.
pub fn luminance_light(name: &str, s: Spectrum, colorimetry: &Colorimetry, design: bool) -> SpectrumEntry {
    let y = colorimetry.luminance().dot(&s.0);
    let s = if y > 0.0 { s.scaled(1.0 / y) } else { s };
    entry(name, Kind::Light, s, design)
}

/// A colour cell.
pub fn cell(light: usize, reflectance: usize, target: Vector3<f64>, weight: f64) -> ColourCell {
    ColourCell { light, reflectance, target, notation: TargetNotation::Linear, weight, free: None, enabled: true }
}

/// Built-in illuminants and Planck radiators, cycled, as tabulated.
fn library_light(k: usize) -> Spectrum {
    const NAMES: [&str; 6] = ["D65", "A", "F11", "D50", "F2", "LED_B3"];
    if k < NAMES.len() {
        Spectrum::illuminant(NAMES[k]).unwrap_or(Spectrum::flat(1.0))
    } else {
        Spectrum::planck(2000.0 + 700.0 * (k - NAMES.len()) as f64).unwrap_or(Spectrum::flat(1.0))
    }
}

/// Starting lights for designed palettes: [`library_light`] at luminance 1.
fn start_light(k: usize, colorimetry: &Colorimetry) -> Spectrum {
    let s = library_light(k);
    let y = colorimetry.luminance().dot(&s.0);
    if y > 0.0 { s.scaled(1.0 / y) } else { s }
}

/// How the spectra of a capacity palette start.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CapacityStart {
    /// Lights from built-in illuminants and Planck radiators, reflectances from ColorChecker patches.
    #[default]
    Library,
    /// Every light and every reflectance flat.
    Flat,
    /// Smooth random spectra ([`smooth_spectrum`]), drawn after the targets.
    Random,
}

/// How the starting lights of a capacity palette are scaled.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CapacityLightScale {
    /// Luminance 1 (a light on a flat reflectance of 1 has Y = 1, the white of linear sRGB).
    #[default]
    Luminance,
    /// Unit L2 norm of the 31 samples.
    L2,
    /// As tabulated (illuminants peak near 100); flat and random starts use peak 1.
    Raw,
}

/// Variations of the capacity protocol a checker might use; [`Default`] is [`capacity_palette`].
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct CapacityOptions {
    /// How the lights and reflectances start (default: illuminants, Planck radiators and ColorChecker patches).
    pub start: CapacityStart,
    /// How the starting lights are scaled (default: luminance 1).
    pub light_scale: CapacityLightScale,
    /// Reflectances bounded to `[0, 1]` instead of `[0, ∞)`.
    pub reflectances_below_one: bool,
}

/// The TOG 2009 Fig. 3 capacity protocol: n designed lights (starting from illuminants / Planck
/// radiators), n designed reflectances (starting from ColorChecker patches), every cell a uniform random
/// linear-RGB target, all samples ≥ 0, smoothness 0.001.
pub fn capacity_palette(n: usize, seed: u64, colorimetry: &Colorimetry) -> Palette {
    capacity_palette_with(n, seed, colorimetry, &CapacityOptions::default())
}

/// [`capacity_palette`] with another start, light scale or reflectance bound. The targets depend on
/// `n` and `seed` only, so variants of one seed share their targets.
pub fn capacity_palette_with(n: usize, seed: u64, colorimetry: &Colorimetry, options: &CapacityOptions) -> Palette {
    let mut rng = Rng::new(seed);
    let mut colours = Vec::new();
    for l in 0..n {
        for r in 0..n {
            let t = Vector3::new(rng.uniform(), rng.uniform(), rng.uniform());
            colours.push(cell(l, r, t, 1.0));
        }
    }
    let patches: Vec<&str> = Spectrum::colorchecker_names().collect();
    let light_start = |k: usize, rng: &mut Rng| match options.start {
        CapacityStart::Library => library_light(k),
        CapacityStart::Flat => Spectrum::flat(1.0),
        CapacityStart::Random => smooth_spectrum(rng),
    };
    let mut raw_lights: Vec<Spectrum> = (0..n).map(|k| light_start(k, &mut rng)).collect();
    for s in raw_lights.iter_mut() {
        // A random start can come out all zero after clipping; lift it so its scale is defined.
        if s.0.max() <= 0.0 {
            *s = Spectrum::flat(1.0);
        }
    }
    let lights = raw_lights
        .into_iter()
        .enumerate()
        .map(|(k, s)| {
            let s = match options.light_scale {
                CapacityLightScale::Luminance => {
                    let y = colorimetry.luminance().dot(&s.0);
                    if y > 0.0 { s.scaled(1.0 / y) } else { s }
                }
                CapacityLightScale::L2 => {
                    let l = s.l2_norm();
                    if l > 0.0 { s.scaled(1.0 / l) } else { s }
                }
                CapacityLightScale::Raw => s,
            };
            entry(&format!("light{k}"), Kind::Light, s, true)
        })
        .collect();
    let reflectances = (0..n)
        .map(|k| {
            let s = match options.start {
                CapacityStart::Library => {
                    Spectrum::colorchecker(patches[k % patches.len()]).unwrap_or(Spectrum::flat(0.5))
                }
                CapacityStart::Flat => Spectrum::flat(0.5),
                CapacityStart::Random => smooth_spectrum(&mut rng),
            };
            entry(&format!("refl{k}"), Kind::Reflectance, s, true)
        })
        .collect();
    let upper = if options.reflectances_below_one { 1.0 } else { f64::INFINITY };
    Palette {
        name: format!("capacity {n}x{n} seed {seed}"),
        settings: Settings {
            smoothness: 0.001,
            reflectance_bounds: Bounds::new(0.0, upper),
            light_bounds: Bounds::new(0.0, f64::INFINITY),
            ..Settings::default()
        },
        lights,
        reflectances,
        colours,
        free: Vec::new(),
        mixtures: Vec::new(),
        paths: Vec::new(),
    }
}

/// `count` designed reflectances under D65, A and F11 (fixed), 3 cells each, `[0, 1]` bounds.
/// Targets are the colours of random smooth reflectances, perturbed per channel by ±25 % so that most
/// designs press against the bounds.
pub fn batch_palette(count: usize, seed: u64, colorimetry: &Colorimetry) -> Palette {
    batch_palette_with(count, seed, colorimetry, true)
}

/// As [`batch_palette`], but every target is the colour of its random smooth reflectance (in `[0, 1]`), so
/// every target is reachable; smoothness still pulls the designs from the exact colours a little.
pub fn reachable_batch_palette(count: usize, seed: u64, colorimetry: &Colorimetry) -> Palette {
    let mut p = batch_palette_with(count, seed, colorimetry, false);
    p.name = format!("reachable batch {count} seed {seed}");
    p
}

fn batch_palette_with(count: usize, seed: u64, colorimetry: &Colorimetry, perturb: bool) -> Palette {
    let mut rng = Rng::new(seed);
    let lights: Vec<SpectrumEntry> = ["D65", "A", "F11"]
        .iter()
        .map(|n| luminance_light(n, Spectrum::illuminant(n).unwrap_or(Spectrum::flat(1.0)), colorimetry, false))
        .collect();
    let mut reflectances = Vec::with_capacity(count);
    let mut colours = Vec::with_capacity(3 * count);
    for r in 0..count {
        let truth = smooth_spectrum(&mut rng);
        reflectances.push(entry(&format!("r{r}"), Kind::Reflectance, Spectrum::flat(0.5), true));
        for (l, light) in lights.iter().enumerate() {
            let c = colorimetry.rgb(&light.spectrum, &truth);
            let mut jitter = || if perturb { rng.range(0.75, 1.25) } else { 1.0 };
            let t = Vector3::new(c[0] * jitter(), c[1] * jitter(), c[2] * jitter());
            colours.push(cell(l, r, t, 1.0));
        }
    }
    Palette {
        name: format!("batch {count} seed {seed}"),
        settings: Settings { reflectance_bounds: Bounds::new(0.0, 1.0), ..Settings::default() },
        lights,
        reflectances,
        colours,
        free: Vec::new(),
        mixtures: Vec::new(),
        paths: Vec::new(),
    }
}

/// A random convex palette: 2–4 lights and 2–5 reflectances; each side randomly designed, but no cell
/// joins two designed spectra (cells between a designed light and a designed reflectance are left out).
/// Weights span 0.1–10, some cells are disabled or weight 0, some join one of up to two free groups,
/// bounds are random (sometimes absent), smoothness 0–0.01.
pub fn convex_palette(seed: u64, colorimetry: &Colorimetry) -> Palette {
    let mut rng = Rng::new(seed);
    let nl = 2 + rng.index(3);
    let nr = 2 + rng.index(4);
    let design_lights = rng.uniform() < 0.35;
    let lights: Vec<SpectrumEntry> = (0..nl)
        .map(|k| {
            let mut e = entry(&format!("L{k}"), Kind::Light, start_light(k, colorimetry), design_lights && k % 2 == 0);
            if e.design && rng.uniform() < 0.5 {
                e.bounds = Some(Bounds::new(0.0, rng.range(0.8, 3.0)));
            }
            e
        })
        .collect();
    let reflectances: Vec<SpectrumEntry> = (0..nr)
        .map(|k| {
            let designed = !design_lights || k % 2 == 1;
            let mut e = entry(&format!("R{k}"), Kind::Reflectance, smooth_spectrum(&mut rng), designed);
            if designed && rng.uniform() < 0.3 {
                e.bounds = Some(Bounds::new(rng.range(0.0, 0.2), rng.range(0.5, 1.0)));
            }
            e
        })
        .collect();
    let nfree = rng.index(3);
    let free: Vec<FreeGroup> = (0..nfree)
        .map(|g| FreeGroup {
            name: format!("G{g}"),
            lower: Vector3::from_element(rng.range(0.0, 0.2)),
            upper: Vector3::from_element(rng.range(0.3, 0.9)),
        })
        .collect();
    let mut colours = Vec::new();
    for (l, light) in lights.iter().enumerate() {
        for (r, refl) in reflectances.iter().enumerate() {
            if light.design && refl.design {
                continue;
            }
            if !light.design && !refl.design && rng.uniform() < 0.5 {
                continue;
            }
            if rng.uniform() < 0.2 {
                continue;
            }
            let t = Vector3::new(rng.range(-0.05, 1.0), rng.range(0.0, 1.0), rng.range(0.0, 1.1));
            let w = 10f64.powf(rng.range(-1.0, 1.0));
            let mut c = cell(l, r, t, w);
            let roll = rng.uniform();
            if roll < 0.05 {
                c.weight = 0.0;
            } else if roll < 0.1 {
                c.enabled = false;
            } else if nfree > 0 && roll < 0.3 {
                c.free = Some(rng.index(nfree));
            }
            colours.push(c);
        }
    }
    let bounded = rng.uniform() < 0.8;
    Palette {
        name: format!("convex seed {seed}"),
        settings: Settings {
            smoothness: if rng.uniform() < 0.2 { 0.0 } else { rng.range(0.0, 0.01) },
            reflectance_bounds: if bounded { Bounds::new(0.0, 1.0) } else { Bounds::UNBOUNDED },
            light_bounds: if bounded { Bounds::new(0.0, f64::INFINITY) } else { Bounds::UNBOUNDED },
            ..Settings::default()
        },
        lights,
        reflectances,
        colours,
        free,
        mixtures: Vec::new(),
        paths: Vec::new(),
    }
}

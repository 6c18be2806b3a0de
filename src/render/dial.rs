//! The light dial: a path through lights of the palette. Frame k of N sits at `t = k/(N−1)` along the
//! path (t = 0 for a single frame), and mixes the two neighbouring lights linearly.

use crate::spectrum::Spectrum;

/// One light the dial visits.
#[derive(Clone, Debug, PartialEq)]
pub struct DialStop {
    pub name: String,
    pub spectrum: Spectrum,
}

/// A path through lights.
#[derive(Clone, Debug, PartialEq)]
pub struct Dial {
    pub stops: Vec<DialStop>,
}

impl Dial {
    /// A dial over at least one light.
    pub fn new(stops: Vec<DialStop>) -> Option<Dial> {
        if stops.is_empty() { None } else { Some(Dial { stops }) }
    }

    /// Position of frame `k` of `n` along the path, in [0, 1].
    pub fn position(k: usize, n: usize) -> f64 {
        if n <= 1 { 0.0 } else { (k as f64 / (n - 1) as f64).clamp(0.0, 1.0) }
    }

    /// The weight of every stop at position t (two neighbours, linear; they sum to 1).
    pub fn weights(&self, t: f64) -> Vec<f64> {
        let n = self.stops.len();
        let mut w = vec![0.0; n];
        if n == 1 {
            w[0] = 1.0;
            return w;
        }
        let u = t.clamp(0.0, 1.0) * (n - 1) as f64;
        let i = (u.floor() as usize).min(n - 2);
        let f = u - i as f64;
        w[i] = 1.0 - f;
        w[i + 1] += f;
        w
    }

    /// The mixed light at position t.
    pub fn light_at(&self, t: f64) -> Spectrum {
        let w = self.weights(t);
        let mut s = Spectrum::flat(0.0);
        for (stop, wi) in self.stops.iter().zip(w) {
            if wi != 0.0 {
                s.0 += stop.spectrum.0 * wi;
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dial() -> Dial {
        let stop = |name: &str, v: f64| DialStop { name: name.into(), spectrum: Spectrum::flat(v) };
        Dial::new(vec![stop("a", 1.0), stop("b", 2.0), stop("c", 4.0)]).unwrap()
    }

    #[test]
    fn frames_walk_the_path_and_mix_neighbours() {
        let d = dial();
        assert_eq!(Dial::position(0, 5), 0.0);
        assert_eq!(Dial::position(4, 5), 1.0);
        assert_eq!(Dial::position(0, 1), 0.0);
        assert_eq!(d.light_at(0.0).0[0], 1.0);
        assert_eq!(d.light_at(0.5).0[0], 2.0);
        assert_eq!(d.light_at(1.0).0[0], 4.0);
        assert!((d.light_at(0.25).0[0] - 1.5).abs() < 1e-12);
        assert!((d.light_at(0.75).0[0] - 3.0).abs() < 1e-12);
        let w = d.weights(0.6);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12 && w[0] == 0.0);
        assert!(Dial::new(vec![]).is_none());
    }
}

//! The unknowns and their stacked layout: the groups of unknowns ([`Unit`]) and their current values
//! ([`Values`]), which units are solved together ([`Block`]), where each unit's samples sit in a stacked
//! vector ([`Layout`]: gather, scatter, bounds), and the bounded linear least-squares problem of a linear
//! block ([`LinearSystem`]). Re-exported by `super::system`, which builds the design on them; this file
//! imports nothing of it.

use crate::palette::Palette;
use crate::spectrum::{SAMPLES, Spectrum};
use nalgebra::{DMatrix, DVector, Vector3};

/// A group of unknowns.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Unit {
    /// The 31 samples of the light at this index of `palette.lights`.
    Light(usize),
    /// The 31 samples of the reflectance at this index of `palette.reflectances`.
    Reflectance(usize),
    /// The linear-sRGB colour (3 unknowns) of the free-colour group at this index of `palette.free`.
    Free(usize),
}

impl Unit {
    /// Number of unknowns in the unit.
    pub(crate) fn len(&self) -> usize {
        match self {
            Unit::Free(_) => 3,
            _ => SAMPLES,
        }
    }
}

/// Current values of every spectrum and free colour.
#[derive(Clone, Debug, PartialEq)]
pub struct Values {
    /// One spectrum per `palette.lights` entry, same order: a designed light's current samples, a fixed
    /// light's resolved ones.
    pub lights: Vec<Spectrum>,
    /// One spectrum per `palette.reflectances` entry, same order: designed or resolved samples as for `lights`.
    pub reflectances: Vec<Spectrum>,
    /// One linear-sRGB colour per `palette.free` group, same order.
    pub free: Vec<Vector3<f64>>,
}

impl Values {
    /// The samples of a unit as a slice.
    pub fn get(&self, unit: Unit) -> &[f64] {
        match unit {
            Unit::Light(i) => self.lights[i].as_slice(),
            Unit::Reflectance(i) => self.reflectances[i].as_slice(),
            Unit::Free(g) => self.free[g].as_slice(),
        }
    }

    /// Overwrite a unit's values.
    pub(crate) fn set(&mut self, unit: Unit, v: &[f64]) {
        match unit {
            Unit::Light(i) => self.lights[i].0.copy_from_slice(v),
            Unit::Reflectance(i) => self.reflectances[i].0.copy_from_slice(v),
            Unit::Free(g) => self.free[g].copy_from_slice(v),
        }
    }
}

/// A set of units that must be solved together, and the terms that touch them.
#[derive(Clone, Debug, Default)]
pub struct Block {
    pub units: Vec<Unit>,
    /// Indices into the design's terms (`Design::terms`).
    pub terms: Vec<usize>,
    /// True when a term has both its light and its reflectance in the block.
    pub bilinear: bool,
}

/// Where each unit's unknowns sit in a stacked vector.
#[derive(Clone, Debug)]
pub struct Layout {
    pub(crate) units: Vec<(Unit, usize)>,
    len: usize,
}

impl Layout {
    /// The layout of `units` stacked in the order given, each unit's unknowns (31 or 3) after the last's.
    pub fn new(units: &[Unit]) -> Layout {
        let mut off = 0;
        let units = units
            .iter()
            .map(|u| {
                let o = off;
                off += u.len();
                (*u, o)
            })
            .collect();
        Layout { units, len: off }
    }

    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Offset of a unit, if it is in the layout.
    pub(crate) fn offset(&self, unit: Unit) -> Option<usize> {
        // Layouts are small (a few dozen units at most in practice); a linear scan beats hashing.
        self.units.iter().find(|(u, _)| *u == unit).map(|(_, o)| *o)
    }

    /// Gather the layout's values from `v`.
    pub fn gather(&self, v: &Values) -> DVector<f64> {
        let mut x = DVector::zeros(self.len);
        for (u, o) in &self.units {
            x.rows_mut(*o, u.len()).copy_from_slice(v.get(*u));
        }
        x
    }

    /// Scatter `x` into `v`.
    pub(crate) fn scatter(&self, x: &DVector<f64>, v: &mut Values) {
        for (u, o) in &self.units {
            v.set(*u, x.rows(*o, u.len()).as_slice());
        }
    }

    /// Bounds of the stacked unknowns.
    pub fn bounds(&self, p: &Palette) -> (DVector<f64>, DVector<f64>) {
        let mut lo = DVector::zeros(self.len);
        let mut hi = DVector::zeros(self.len);
        for (u, o) in &self.units {
            let n = u.len();
            match *u {
                Unit::Light(i) | Unit::Reflectance(i) => {
                    let entry = if matches!(u, Unit::Light(_)) { &p.lights[i] } else { &p.reflectances[i] };
                    let b = p.bounds_of(entry);
                    lo.rows_mut(*o, n).fill(b.lower);
                    hi.rows_mut(*o, n).fill(b.upper);
                }
                Unit::Free(g) => {
                    lo.rows_mut(*o, n).copy_from(&p.free[g].lower);
                    hi.rows_mut(*o, n).copy_from(&p.free[g].upper);
                }
            }
        }
        (lo, hi)
    }
}

/// `min ‖A x − b‖²` subject to `lower ≤ x ≤ upper`.
#[derive(Clone, Debug)]
pub struct LinearSystem {
    /// Shared between the systems of a batch that have the same A (no copy per design).
    pub a: std::sync::Arc<DMatrix<f64>>,
    pub b: DVector<f64>,
    pub(crate) lower: DVector<f64>,
    pub(crate) upper: DVector<f64>,
}

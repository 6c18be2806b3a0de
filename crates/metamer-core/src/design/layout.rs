//! Blocks of unknowns and their stacked layout: which units are solved together ([`Block`]), where each
//! unit's samples sit in a stacked vector ([`Layout`]: gather, scatter, bounds), and the bounded linear
//! least-squares problem of a linear block ([`LinearSystem`]). Re-exported by [`super::system`].

use super::system::{Design, Unit, Values};
use nalgebra::{DMatrix, DVector};

/// A set of units that must be solved together, and the terms that touch them.
#[derive(Clone, Debug, Default)]
pub struct Block {
    pub units: Vec<Unit>,
    /// Indices into [`Design::terms`].
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
    pub fn bounds(&self, design: &Design) -> (DVector<f64>, DVector<f64>) {
        let mut lo = DVector::zeros(self.len);
        let mut hi = DVector::zeros(self.len);
        let p = design.palette;
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
    pub a: DMatrix<f64>,
    pub b: DVector<f64>,
    pub(crate) lower: DVector<f64>,
    pub(crate) upper: DVector<f64>,
}

//! Assembly of the pinned objective (DESIGN_SPEC §2, seed Eqs. 18–24).
//!
//! The unknowns are grouped in [`Unit`]s: the 31 samples of one designed light or reflectance, or the
//! linear-RGB colour of one free group. Every active cell contributes
//!
//! * 3 colour rows `ω/√3 · (T(E, S) − c)`, where `T(E, S) = Q_rgb,31 (E ∘ S)` (full) or
//!   `Q_rgb,m Λ(Q_m,31 E) Q_m,31 S` (subspace, `fit_in_subspace`) and `c` is the target or the group's
//!   unknown colour, and
//! * 3 subspace-error rows `ω_F · ω/√3 · F(E) S` when `subspace_error > 0`,
//!
//! and every designed spectrum 31 smoothness rows `ω_D · D x` with D the 2/−1 tridiagonal scaled by
//! `1/(√31·√6)`. Both T and F are symmetric bilinear forms (`Λ(a) b = Λ(b) a` because
//! `G_ijk = B⁺_i (B_j ∘ B_k)` is symmetric in j, k), so fixing either side leaves a linear map of the
//! other: [`Design::operator`] builds it.
//!
//! Which rows exist: a cell with `use = false` or weight 0 has none; a cell whose light and reflectance
//! are both fixed and that joins no free group has none either (its residual is a constant the design
//! cannot change, and the table of DESIGN_SPEC §2 only defines rows with a designed side or a free
//! colour). The subspace-error rows exist only where a side is designed.

use crate::basis::Basis;
use crate::colorimetry::{Colorimetry, Q31};
use crate::palette::mixing::{light_of, mix_at, route_dial, sample_positions};
use crate::palette::{Bounds, Kind, Mix, Palette};
use crate::spectrum::{SAMPLES, Spectrum};
use nalgebra::{DMatrix, DVector, Vector3};
use rayon::prelude::*;

use super::DesignError;
pub use super::layout::{Block, Layout, LinearSystem, Unit, Values};

/// The scale of the smoothness operator: `D / (√31 · √6)`.
pub fn smoothness_scale() -> f64 {
    1.0 / ((SAMPLES as f64).sqrt() * 6f64.sqrt())
}

/// Which bilinear form a row block uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Form {
    /// `Q_rgb,31 (E ∘ S)`.
    Full,
    /// `Q_rgb,m Λ(Q_m,31 E) Q_m,31 S`.
    Subspace,
    /// `F(E) S`, full minus subspace.
    Error,
}

/// Which criterion of the palette a term comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Origin {
    /// `palette.colours[k]`.
    Cell(usize),
    /// `palette.mixtures[k]`.
    Mixture(usize),
    /// Design sample `sample` of `palette.paths[path]`.
    Path { path: usize, sample: usize },
}

/// The rows one active cell contributes. Its light is a fixed mixture `Σ wᵢ Eᵢ` of the palette's lights
/// (an ordinary cell's is its one light with weight 1): every form is linear in the light, so
/// `form(Σ wᵢ Eᵢ, S) = Σ wᵢ form(Eᵢ, S)`.
#[derive(Clone, Debug)]
pub struct CellTerm {
    pub origin: Origin,
    /// The light as `(light index, weight)` pairs.
    pub(crate) lights: TermLights,
    pub(crate) reflectance: usize,
    pub(crate) free: Option<usize>,
    /// Linear-RGB target (unused for a free cell).
    pub(crate) target: Vector3<f64>,
    /// ω/√3.
    pub scale: f64,
    /// Full or subspace colour rows.
    pub(crate) form: Form,
    /// ω_F·ω/√3, 0 when there are no subspace-error rows.
    pub(crate) error_scale: f64,
}

/// A term's light as `(light index, weight)` pairs ([`Mix`]): an ordinary cell's one light held in place
/// rather than in a vector of one pair (a batch has thousands of cells, and the solve built them all on the
/// calling thread). Read as a slice.
#[derive(Clone, Debug)]
pub(crate) enum TermLights {
    One([(usize, f64); 1]),
    Mix(Mix),
}

impl TermLights {
    pub(crate) fn as_slice(&self) -> &[(usize, f64)] {
        match self {
            TermLights::One(one) => one,
            TermLights::Mix(mix) => mix,
        }
    }
}

impl std::ops::Deref for TermLights {
    type Target = [(usize, f64)];
    fn deref(&self) -> &[(usize, f64)] {
        self.as_slice()
    }
}

impl<'a> IntoIterator for &'a TermLights {
    type Item = &'a (usize, f64);
    type IntoIter = std::slice::Iter<'a, (usize, f64)>;
    fn into_iter(self) -> Self::IntoIter {
        self.as_slice().iter()
    }
}

/// The design problem of a palette: which units are unknown and which rows exist.
#[derive(Clone, Debug)]
pub struct Design<'a> {
    pub(crate) palette: &'a Palette,
    pub(crate) basis: Option<&'a Basis>,
    pub(crate) q_rgb: Q31,
    /// One term per active criterion that touches an unknown (a cell, a mixture, or one design sample of a
    /// path): the cells', then the mixtures', then the paths'; blocks refer to them by index.
    pub terms: Vec<CellTerm>,
    /// ω_D (0 = no smoothness rows).
    pub smoothness: f64,
}

impl<'a> Design<'a> {
    /// Check the palette and build its terms. Errors name what is wrong.
    pub fn new(palette: &'a Palette, basis: Option<&'a Basis>, colorimetry: &Colorimetry) -> Result<Self, DesignError> {
        validate(palette)?;
        let s = &palette.settings;
        let uses_basis = s.fit_in_subspace || s.subspace_error > 0.0;
        if uses_basis && basis.is_none() {
            return Err(DesignError::Invalid(format!(
                "palette \"{}\": settings use {} but no trained basis was given to the solver",
                palette.name,
                if s.fit_in_subspace { "fit_in_subspace = true" } else { "subspace_error > 0" }
            )));
        }
        let form = if s.fit_in_subspace { Form::Subspace } else { Form::Full };
        let mut terms = Vec::with_capacity(palette.colours.len() + palette.mixtures.len());
        let mut push =
            |origin: Origin, lights: TermLights, reflectance: usize, free: Option<usize>, target, weight: f64| {
                let ld = lights.iter().any(|&(i, _)| palette.lights[i].design);
                let rd = palette.reflectances[reflectance].design;
                if !(ld || rd || free.is_some()) {
                    return;
                }
                let scale = weight / 3f64.sqrt();
                let error_scale = if ld || rd { s.subspace_error * scale } else { 0.0 };
                terms.push(CellTerm { origin, lights, reflectance, free, target, scale, form, error_scale });
            };
        for (k, c) in palette.colours.iter().enumerate() {
            if c.is_active() {
                push(Origin::Cell(k), TermLights::One([(c.light, 1.0)]), c.reflectance, c.free, c.target, c.weight);
            }
        }
        for (k, m) in palette.mixtures.iter().enumerate() {
            if m.is_active() {
                push(Origin::Mixture(k), TermLights::Mix(m.mix.clone()), m.reflectance, m.free, m.target, m.weight);
            }
        }
        for (k, q) in palette.paths.iter().enumerate() {
            if !q.is_active() {
                continue;
            }
            let dial = route_dial(&palette.lights, &q.route)
                .map_err(|e| DesignError::Invalid(format!("palette \"{}\": paths[{k}]: {e}", palette.name)))?;
            let positions = sample_positions(q.samples);
            // The path counts like one cell whose error is the root mean square over its samples.
            let weight = q.weight / (positions.len() as f64).sqrt();
            for (j, &t) in positions.iter().enumerate() {
                push(
                    Origin::Path { path: k, sample: j },
                    TermLights::Mix(mix_at(&dial, t)),
                    q.reflectance,
                    q.free,
                    q.target,
                    weight,
                );
            }
        }
        Ok(Design { palette, basis, q_rgb: colorimetry.q_rgb, terms, smoothness: s.smoothness })
    }

    /// Every unknown unit, in a fixed order (lights, reflectances, free groups).
    pub fn units(&self) -> Vec<Unit> {
        let p = self.palette;
        let lights = (0..p.lights.len()).filter(|&i| p.lights[i].design).map(Unit::Light);
        let refl = (0..p.reflectances.len()).filter(|&i| p.reflectances[i].design).map(Unit::Reflectance);
        lights.chain(refl).chain((0..p.free.len()).map(Unit::Free)).collect()
    }

    /// The starting values: the palette's spectra, free colours at the mean of their cells' current
    /// colours, clamped to the group's box.
    pub fn start_values(&self) -> Values {
        let p = self.palette;
        let lights: Vec<Spectrum> = p.lights.iter().map(|e| e.spectrum).collect();
        let reflectances: Vec<Spectrum> = p.reflectances.iter().map(|e| e.spectrum).collect();
        let mut free = vec![Vector3::zeros(); p.free.len()];
        let mut count = vec![0usize; p.free.len()];
        for t in &self.terms {
            if let Some(g) = t.free {
                free[g] += self.q_rgb * light_of(&t.lights, &lights).0.component_mul(&reflectances[t.reflectance].0);
                count[g] += 1;
            }
        }
        for (g, f) in free.iter_mut().enumerate() {
            if count[g] > 0 {
                *f /= count[g] as f64;
            }
            for ch in 0..3 {
                f[ch] = clamp_finite(f[ch], p.free[g].lower[ch], p.free[g].upper[ch]);
            }
        }
        let mut v = Values { lights, reflectances, free };
        // Designed spectra start inside their bounds (clamped in place: the bounds of a spectrum are the
        // same for each of its samples, those of a free group are its box).
        for unit in self.units() {
            match unit {
                Unit::Light(i) => clamp_spectrum(&mut v.lights[i], p.bounds_of(&p.lights[i])),
                Unit::Reflectance(i) => clamp_spectrum(&mut v.reflectances[i], p.bounds_of(&p.reflectances[i])),
                Unit::Free(g) => {
                    for ch in 0..3 {
                        v.free[g][ch] = clamp_finite(v.free[g][ch], p.free[g].lower[ch], p.free[g].upper[ch]);
                    }
                }
            }
        }
        v
    }

    /// Lower and upper bounds of a unit's unknowns.
    pub fn bounds_of(&self, unit: Unit) -> (Vec<f64>, Vec<f64>) {
        let p = self.palette;
        let spectrum = |b: Bounds| (vec![b.lower; SAMPLES], vec![b.upper; SAMPLES]);
        match unit {
            Unit::Light(i) => spectrum(p.bounds_of(&p.lights[i])),
            Unit::Reflectance(i) => spectrum(p.bounds_of(&p.reflectances[i])),
            Unit::Free(g) => (p.free[g].lower.as_slice().to_vec(), p.free[g].upper.as_slice().to_vec()),
        }
    }

    /// The 3×31 linear map `x ↦ form(partner, x)` (the bilinear forms are symmetric).
    pub(crate) fn operator(&self, form: Form, partner: &Spectrum) -> Q31 {
        match (form, self.basis) {
            (Form::Full, _) => diag_right(&self.q_rgb, partner),
            (Form::Subspace, Some(b)) => b.subspace_operator(partner),
            (Form::Error, Some(b)) => diag_right(&self.q_rgb, partner) - b.subspace_operator(partner),
            // Design::new refuses subspace forms without a basis.
            (_, None) => Q31::zeros(),
        }
    }

    /// `form(E, S)`.
    pub(crate) fn apply(&self, form: Form, e: &Spectrum, s: &Spectrum) -> Vector3<f64> {
        let full = || self.q_rgb * e.0.component_mul(&s.0);
        match (form, self.basis) {
            (Form::Full, _) => full(),
            (Form::Subspace, Some(b)) => b.rgb_lambda(e, s),
            (Form::Error, Some(b)) => full() - b.rgb_lambda(e, s),
            (_, None) => Vector3::zeros(),
        }
    }

    /// The light of a term at `v`: `Σ wᵢ Eᵢ`.
    pub(crate) fn term_light(&self, t: &CellTerm, v: &Values) -> Spectrum {
        match t.lights.as_slice() {
            [(i, w)] if *w == 1.0 => v.lights[*i],
            mix => light_of(mix, &v.lights),
        }
    }

    /// The colour residual `ω/√3 (T(E,S) − c)` and the error residual of one term.
    pub(crate) fn term_residuals(&self, t: &CellTerm, v: &Values) -> (Vector3<f64>, Vector3<f64>) {
        self.term_residuals_with(t, v, None)
    }

    /// [`Design::term_residuals`] with the term's colour `apply(t.form, E, S)` given when it is known.
    fn term_residuals_with(
        &self,
        t: &CellTerm,
        v: &Values,
        applied: Option<Vector3<f64>>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        // The light (a copy of a spectrum) only when a product needs it.
        let e = || self.term_light(t, v);
        let s = &v.reflectances[t.reflectance];
        let c = t.free.map(|g| v.free[g]).unwrap_or(t.target);
        let colour = (applied.unwrap_or_else(|| self.apply(t.form, &e(), s)) - c) * t.scale;
        let error =
            if t.error_scale > 0.0 { self.apply(Form::Error, &e(), s) * t.error_scale } else { Vector3::zeros() };
        (colour, error)
    }

    /// The pinned objective at `v`: the sum of squares of every row.
    pub fn objective(&self, v: &Values) -> f64 {
        self.objective_with(v, false)
    }

    /// [`Design::objective`], its terms' and spectra's parts computed on the pool when `parallel` and there
    /// are many of them; they are summed in order on the calling thread either way, so the result has the
    /// same bits.
    pub(crate) fn objective_with(&self, v: &Values, parallel: bool) -> f64 {
        self.objective_with_colours(v, parallel, &|_| None)
    }

    /// [`Design::objective_with`] (the same bits) taking the full colour of cell k (`palette.colours[k]`)
    /// at `v` from `cell_colour(k)` where it gives one: a cell's term in full ([`Form::Full`]) is the
    /// product `Q_rgb (E ∘ S)` of the cell's light and reflectance, which the cells' pass makes with the
    /// same matrix ([`crate::colorimetry::Colorimetry::rgb`], [`super::CellResult::rgb_full`]); taken from
    /// there it is not made twice (a batch's 3600 cells: 1.8 M instructions).
    pub(crate) fn objective_with_colours(
        &self,
        v: &Values,
        parallel: bool,
        cell_colour: &(dyn Fn(usize) -> Option<Vector3<f64>> + Sync),
    ) -> f64 {
        self.terms_objective_with_colours(v, parallel, cell_colour) + self.smoothness_objective(v, parallel)
    }

    /// The terms' part of [`Design::objective_with_colours`] (without the smoothness part). A term whose
    /// colour is given costs a residual only, so the terms go to the pool only when many have none (a
    /// batch's cells all have theirs: a pass on the pool would cost more in hand-overs than it shares).
    pub(crate) fn terms_objective_with_colours(
        &self,
        v: &Values,
        parallel: bool,
        cell_colour: &(dyn Fn(usize) -> Option<Vector3<f64>> + Sync),
    ) -> f64 {
        let given = |t: &CellTerm| match (t.origin, t.form) {
            (Origin::Cell(k), Form::Full) => cell_colour(k),
            _ => None,
        };
        let term = |t: &CellTerm| {
            let (c, e) = self.term_residuals_with(t, v, given(t));
            c.norm_squared() + e.norm_squared()
        };
        let mut f = 0.0;
        let made = || self.terms.iter().filter(|t| given(t).is_none()).count();
        if parallel && self.terms.len() >= PARALLEL_MIN && made() >= PARALLEL_MIN {
            let parts: Vec<f64> = self.terms.par_iter().with_min_len(PARALLEL_MIN / 2).map(term).collect();
            for x in parts {
                f += x;
            }
        } else {
            for t in &self.terms {
                f += term(t);
            }
        }
        f
    }

    /// The smoothness part of the objective.
    pub(crate) fn smoothness_objective(&self, v: &Values, parallel: bool) -> f64 {
        if self.smoothness <= 0.0 {
            return 0.0;
        }
        let w = self.smoothness * smoothness_scale();
        let units: Vec<Unit> = self.units().into_iter().filter(|u| !matches!(u, Unit::Free(_))).collect();
        if parallel && units.len() >= PARALLEL_MIN {
            let parts: Vec<f64> =
                units.par_iter().with_min_len(PARALLEL_MIN / 2).map(|u| smoothness_sq(v.get(*u), w)).collect();
            parts.into_iter().sum()
        } else {
            units.iter().map(|u| smoothness_sq(v.get(*u), w)).sum()
        }
    }

    /// The units each term touches (designed spectra and its free group), appended to `u` (no allocation
    /// once `u` has room).
    fn term_units(&self, t: &CellTerm, u: &mut Vec<Unit>) {
        for &(i, _) in &t.lights {
            if self.palette.lights[i].design {
                u.push(Unit::Light(i));
            }
        }
        if self.palette.reflectances[t.reflectance].design {
            u.push(Unit::Reflectance(t.reflectance));
        }
        if let Some(g) = t.free {
            u.push(Unit::Free(g));
        }
    }

    /// Is the term bilinear (light and reflectance both designed)?
    pub(crate) fn is_bilinear(&self, t: &CellTerm) -> bool {
        t.lights.iter().any(|&(i, _)| self.palette.lights[i].design) && self.palette.reflectances[t.reflectance].design
    }

    /// Split the unknowns into independent blocks: units connected through a shared term.
    pub fn blocks(&self) -> Vec<Block> {
        let all: Vec<usize> = (0..self.terms.len()).collect();
        self.components(&self.units(), &all)
    }

    /// Connected components of `units` through `terms` (indices into [`Design::terms`]); units outside
    /// `units` count as fixed and connect nothing. Each term goes to the component of its first unit in
    /// the set (terms touching none of `units` are dropped).
    pub(crate) fn components(&self, units: &[Unit], terms: &[usize]) -> Vec<Block> {
        // Positions of the units in `units`, by kind and index (dense tables: a batch has thousands of
        // units and terms, and hashing each lookup was most of this function's cost).
        let p = self.palette;
        const NONE: usize = usize::MAX;
        let mut lights = vec![NONE; p.lights.len()];
        let mut refl = vec![NONE; p.reflectances.len()];
        let mut free = vec![NONE; p.free.len()];
        for (i, u) in units.iter().enumerate() {
            let (table, k) = match *u {
                Unit::Light(k) => (&mut lights, k),
                Unit::Reflectance(k) => (&mut refl, k),
                Unit::Free(k) => (&mut free, k),
            };
            // A unit listed twice counts at its last position (as a map from unit to position would).
            if let Some(slot) = table.get_mut(k) {
                *slot = i;
            }
        }
        let at = |table: &[usize], k: usize| table.get(k).copied().filter(|&i| i != NONE);
        let index_of = |u: &Unit| match *u {
            Unit::Light(k) => at(&lights, k),
            Unit::Reflectance(k) => at(&refl, k),
            Unit::Free(k) => at(&free, k),
        };
        let mut parent: Vec<usize> = (0..units.len()).collect();
        fn find(parent: &mut [usize], mut i: usize) -> usize {
            while parent[i] != i {
                parent[i] = parent[parent[i]];
                i = parent[i];
            }
            i
        }
        let mut scratch = Vec::with_capacity(4);
        let mut in_set = |t: &CellTerm, out: &mut Vec<usize>| {
            scratch.clear();
            self.term_units(t, &mut scratch);
            out.clear();
            out.extend(scratch.iter().filter_map(index_of));
        };
        let mut us = Vec::with_capacity(4);
        for &ti in terms {
            in_set(&self.terms[ti], &mut us);
            for w in us.windows(2) {
                let a = find(&mut parent, w[0]);
                let b = find(&mut parent, w[1]);
                if a != b {
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
        let mut by_root = vec![NONE; units.len()];
        let mut blocks: Vec<Block> = Vec::new();
        for (i, unit) in units.iter().enumerate() {
            let r = find(&mut parent, i);
            if by_root[r] == NONE {
                blocks.push(Block::default());
                by_root[r] = blocks.len() - 1;
            }
            blocks[by_root[r]].units.push(*unit);
        }
        for &ti in terms {
            let t = &self.terms[ti];
            in_set(t, &mut us);
            if let Some(&first) = us.first() {
                let k = by_root[find(&mut parent, first)];
                blocks[k].terms.push(ti);
                let both =
                    t.lights.iter().any(|&(i, _)| at(&lights, i).is_some()) && at(&refl, t.reflectance).is_some();
                blocks[k].bilinear |= both;
            }
        }
        blocks
    }

    /// The part of the objective a block owns: its terms and its spectra's smoothness.
    pub(crate) fn block_objective(&self, block: &Block, v: &Values) -> f64 {
        let mut f = 0.0;
        for &ti in &block.terms {
            let (c, e) = self.term_residuals(&self.terms[ti], v);
            f += c.norm_squared() + e.norm_squared();
        }
        if self.smoothness > 0.0 {
            let w = self.smoothness * smoothness_scale();
            for u in &block.units {
                if !matches!(u, Unit::Free(_)) {
                    f += smoothness_sq(v.get(*u), w);
                }
            }
        }
        f
    }

    /// What the matrix A of [`Design::linear_system`] depends on, as a short list of numbers: the layout's
    /// shape, the smoothness weight and, per term, where its rows go, which fixed spectrum multiplies the
    /// unknowns, the form, the scales and the free colour's columns. Two systems assembled from the same
    /// [`Values`] with equal keys have bit-identical A (A is a deterministic function of exactly these), so
    /// a factorisation can be shared by key without hashing or comparing A itself.
    pub(crate) fn matrix_key(&self, layout: &Layout, terms: &[usize]) -> Vec<u64> {
        let mut key = Vec::new();
        self.matrix_key_into(layout, terms, &mut key);
        key
    }

    /// [`Design::matrix_key`] written into `key` (cleared first), whose storage a caller reuses from block
    /// to block.
    pub(crate) fn matrix_key_into(&self, layout: &Layout, terms: &[usize], key: &mut Vec<u64>) {
        const NONE: u64 = u64::MAX;
        let opt = |o: Option<usize>| o.map_or(NONE, |o| o as u64);
        key.clear();
        key.reserve(
            2 + layout.units.len() + terms.iter().map(|&ti| 8 + 3 * self.terms[ti].lights.len()).sum::<usize>(),
        );
        key.push(layout.len() as u64);
        key.push((self.smoothness * smoothness_scale()).to_bits());
        key.extend(layout.units.iter().map(|(u, _)| matches!(u, Unit::Free(_)) as u64));
        for &ti in terms {
            let t = &self.terms[ti];
            let ro = layout.offset(Unit::Reflectance(t.reflectance));
            // The spectra held fixed multiply the unknowns: the reflectance when a light is unknown, the
            // lights (with their weights) when the reflectance is.
            key.push(t.lights.len() as u64);
            for &(i, w) in &t.lights {
                key.extend([opt(layout.offset(Unit::Light(i))), i as u64, w.to_bits()]);
            }
            let lo = t.lights.iter().find_map(|&(i, _)| layout.offset(Unit::Light(i)));
            let partner = match (lo, ro) {
                (Some(_), None) => t.reflectance as u64,
                (None, Some(_)) => NONE - 1,
                _ => NONE,
            };
            let form = match t.form {
                Form::Full => 0,
                Form::Subspace => 1,
                Form::Error => 2,
            };
            let free = t.free.and_then(|g| layout.offset(Unit::Free(g)));
            key.extend([opt(lo), opt(ro), partner, form, t.scale.to_bits(), t.error_scale.to_bits(), opt(free)]);
        }
    }

    /// Assemble the linear least-squares system `min ‖A x − b‖²` over `layout`'s units with every other
    /// spectrum and free colour held at `v`. No term may have both of its sides in the layout.
    /// Only `terms` (indices into `self.terms`) are assembled; with `smoothness`, the layout's spectra get
    /// their smoothness rows.
    pub fn linear_system(&self, layout: &Layout, terms: &[usize], v: &Values) -> LinearSystem {
        let (a, b) = self.assemble(layout, terms, v, true);
        let (lower, upper) = layout.bounds(self.palette);
        LinearSystem { a: a.into(), b, lower, upper }
    }

    /// [`Design::linear_system`] with A taken from `a`, a system assembled before from the same [`Values`]
    /// with an equal [`Design::matrix_key`] (so A is bit-identical): only b and the bounds are assembled.
    /// The batch path shares one A between all designs under the same lights this way.
    pub(crate) fn linear_system_with(
        &self,
        a: &std::sync::Arc<DMatrix<f64>>,
        layout: &Layout,
        terms: &[usize],
        v: &Values,
    ) -> LinearSystem {
        let (_, b) = self.assemble(layout, terms, v, false);
        debug_assert_eq!((a.nrows(), a.ncols()), (b.len(), layout.len()));
        let (lower, upper) = layout.bounds(self.palette);
        // The shared matrix itself, not a copy (copying it was 3 % of a batch solve's instructions).
        LinearSystem { a: std::sync::Arc::clone(a), b, lower, upper }
    }

    /// A (empty when `with_matrix` is false) and b of [`Design::linear_system`]: one routine for both, so b
    /// is computed by the same operations whether A is assembled or shared.
    fn assemble(
        &self,
        layout: &Layout,
        terms: &[usize],
        v: &Values,
        with_matrix: bool,
    ) -> (DMatrix<f64>, DVector<f64>) {
        let n = layout.len();
        let w_d = self.smoothness * smoothness_scale();
        let spectra = layout.units.iter().filter(|(u, _)| !matches!(u, Unit::Free(_))).count();
        let mut rows = 0;
        for &ti in terms {
            let t = &self.terms[ti];
            rows += 3 + if t.error_scale > 0.0 { 3 } else { 0 };
        }
        if w_d > 0.0 {
            rows += SAMPLES * spectra;
        }
        let mut a = if with_matrix { DMatrix::zeros(rows, n) } else { DMatrix::zeros(0, 0) };
        let mut b = DVector::zeros(rows);
        let mut r0 = 0;
        for &ti in terms {
            let t = &self.terms[ti];
            let s = &v.reflectances[t.reflectance];
            let ro = layout.offset(Unit::Reflectance(t.reflectance));
            // The lights of the mixture that are unknowns here, and the fixed rest.
            let mut unknown: Vec<(usize, f64)> = Vec::new();
            let mut fixed = Spectrum::flat(0.0);
            for &(i, w) in &t.lights {
                match layout.offset(Unit::Light(i)) {
                    Some(off) => unknown.push((off, w)),
                    None => fixed.0 += v.lights[i].0 * w,
                }
            }
            debug_assert!(unknown.is_empty() || ro.is_none());
            let parts = [(t.form, t.scale, r0), (Form::Error, t.error_scale, r0 + 3)];
            let count = if t.error_scale > 0.0 { 2 } else { 1 };
            for &(form, scale, row) in &parts[..count] {
                let constant = if let Some(off) = ro {
                    if with_matrix {
                        let op = self.operator(form, &fixed) * scale;
                        a.view_mut((row, off), (3, SAMPLES)).copy_from(&op);
                    }
                    Vector3::zeros()
                } else {
                    if with_matrix && !unknown.is_empty() {
                        let op = self.operator(form, s) * scale;
                        for &(off, w) in &unknown {
                            let mut block = a.view_mut((row, off), (3, SAMPLES));
                            block += op * w;
                        }
                    }
                    if t.lights.len() == unknown.len() { Vector3::zeros() } else { self.apply(form, &fixed, s) * scale }
                };
                let mut rhs = -constant;
                if form != Form::Error {
                    match t.free {
                        Some(g) => match layout.offset(Unit::Free(g)) {
                            Some(off) => {
                                if with_matrix {
                                    for k in 0..3 {
                                        a[(row + k, off + k)] = -scale;
                                    }
                                }
                            }
                            None => rhs += v.free[g] * scale,
                        },
                        None => rhs += t.target * scale,
                    }
                }
                b.rows_mut(row, 3).copy_from(&rhs);
            }
            r0 += 3 + if t.error_scale > 0.0 { 3 } else { 0 };
        }
        if w_d > 0.0 && with_matrix {
            let spectra = layout.units.iter().filter(|(u, _)| !matches!(u, Unit::Free(_)));
            for (_, off) in spectra {
                for i in 0..SAMPLES {
                    a[(r0 + i, off + i)] = 2.0 * w_d;
                    if i > 0 {
                        a[(r0 + i, off + i - 1)] = -w_d;
                    }
                    if i + 1 < SAMPLES {
                        a[(r0 + i, off + i + 1)] = -w_d;
                    }
                }
                r0 += SAMPLES;
            }
        }
        (a, b)
    }
}

/// `‖w D x‖²` with D the unscaled 2/−1 tridiagonal.
pub(crate) fn smoothness_sq(x: &[f64], w: f64) -> f64 {
    let n = x.len();
    let mut f = 0.0;
    for i in 0..n {
        let mut d = 2.0 * x[i];
        if i > 0 {
            d -= x[i - 1];
        }
        if i + 1 < n {
            d -= x[i + 1];
        }
        f += (w * d).powi(2);
    }
    f
}

/// `2 w² DᵀD x` added into `g` (the gradient of [`smoothness_sq`]).
pub(crate) fn smoothness_grad(x: &[f64], w: f64, g: &mut [f64]) {
    let n = x.len();
    let mut d = vec![0.0; n];
    for i in 0..n {
        d[i] = 2.0 * x[i] - if i > 0 { x[i - 1] } else { 0.0 } - if i + 1 < n { x[i + 1] } else { 0.0 };
    }
    for i in 0..n {
        let dtd = 2.0 * d[i] - if i > 0 { d[i - 1] } else { 0.0 } - if i + 1 < n { d[i + 1] } else { 0.0 };
        g[i] += 2.0 * w * w * dtd;
    }
}

/// Below this many terms (or spectra) the objective is computed on the calling thread alone: the pool's
/// hand-off costs more than it saves on a designer's palette.
const PARALLEL_MIN: usize = 512;

/// Each sample of `s` clamped into `b` ([`clamp_finite`]).
fn clamp_spectrum(s: &mut Spectrum, b: Bounds) {
    for x in s.0.iter_mut() {
        *x = clamp_finite(*x, b.lower, b.upper);
    }
}

/// Clamp into [lo, hi]; a non-finite value becomes the nearest finite bound or 0.
fn clamp_finite(x: f64, lo: f64, hi: f64) -> f64 {
    let x = if x.is_finite() { x } else { 0.0 };
    x.max(lo).min(hi)
}

/// `Q · diag(p)`.
fn diag_right(q: &Q31, p: &Spectrum) -> Q31 {
    let mut m = *q;
    for (c, v) in p.0.iter().enumerate() {
        m.column_mut(c).scale_mut(*v);
    }
    m
}

/// Refuse palettes whose numbers cannot be designed with: non-finite spectra, targets, weights or
/// settings, negative weights, crossed bounds, dangling indices.
fn validate(p: &Palette) -> Result<(), DesignError> {
    let bad = |what: String| Err(DesignError::Invalid(format!("palette \"{}\": {what}", p.name)));
    let s = &p.settings;
    for (key, v) in [("smoothness", s.smoothness), ("subspace_error", s.subspace_error)] {
        if !(v.is_finite() && v >= 0.0) {
            return bad(format!("settings.{key} = {v} must be a finite number ≥ 0"));
        }
    }
    for (key, b) in [("reflectance_bounds", s.reflectance_bounds), ("light_bounds", s.light_bounds)] {
        if b.lower.is_nan() || b.upper.is_nan() || b.lower > b.upper {
            return bad(format!("settings.{key} = [{}, {}] is not an interval", b.lower, b.upper));
        }
    }
    for (kind, entries) in [(Kind::Light, &p.lights), (Kind::Reflectance, &p.reflectances)] {
        for e in entries {
            if !e.spectrum.is_finite() {
                return bad(format!("{} \"{}\" has a non-finite sample", kind.as_str(), e.name));
            }
            if let Some(b) = e.bounds
                && (b.lower.is_nan() || b.upper.is_nan() || b.lower > b.upper)
            {
                return bad(format!(
                    "{} \"{}\": bounds [{}, {}] are not an interval",
                    kind.as_str(),
                    e.name,
                    b.lower,
                    b.upper
                ));
            }
        }
    }
    for g in &p.free {
        for ch in 0..3 {
            if g.lower[ch].is_nan() || g.upper[ch].is_nan() || g.lower[ch] > g.upper[ch] {
                return bad(format!("free group \"{}\": lower/upper cross in channel {ch}", g.name));
            }
        }
    }
    for (k, m) in p.mixtures.iter().enumerate() {
        if m.reflectance >= p.reflectances.len() || m.mix.iter().any(|&(i, _)| i >= p.lights.len()) {
            return bad(format!("mixtures[{k}] refers to a light or reflectance that does not exist"));
        }
        if m.free.is_some_and(|g| g >= p.free.len()) || !(m.weight.is_finite() && m.weight >= 0.0) {
            return bad(format!("mixtures[{k}]: a dangling free group or a weight that is not a finite number ≥ 0"));
        }
        if m.mix.iter().any(|&(_, w)| !(w.is_finite() && w >= 0.0)) || m.mix.iter().all(|&(_, w)| w == 0.0) {
            return bad(format!("mixtures[{k}].mix: weights must be finite, ≥ 0 and not all 0"));
        }
    }
    for (k, q) in p.paths.iter().enumerate() {
        let lights_ok = match &q.route {
            crate::palette::Route::Lights(o) => o.iter().all(|&i| i < p.lights.len()),
            crate::palette::Route::Dial { off, .. } => off.iter().all(|&i| i < p.lights.len()),
        };
        if q.reflectance >= p.reflectances.len() || !lights_ok || q.free.is_some_and(|g| g >= p.free.len()) {
            return bad(format!("paths[{k}] refers to a light, reflectance or free group that does not exist"));
        }
        if !(q.weight.is_finite() && q.weight >= 0.0) || q.samples < 2 {
            return bad(format!("paths[{k}]: the weight must be a finite number ≥ 0 and samples at least 2"));
        }
    }
    for (k, c) in p.colours.iter().enumerate() {
        if c.light >= p.lights.len() || c.reflectance >= p.reflectances.len() {
            return bad(format!("colours[{k}] refers to a light or reflectance that does not exist"));
        }
        if let Some(g) = c.free
            && g >= p.free.len()
        {
            return bad(format!("colours[{k}] refers to a free group that does not exist"));
        }
        if !(c.weight.is_finite() && c.weight >= 0.0) {
            return bad(format!("colours[{k}].weight = {} must be a finite number ≥ 0", c.weight));
        }
        if c.free.is_none() && c.is_active() && !(c.target.iter().all(|v| v.is_finite())) {
            return bad(format!("colours[{k}].target is not finite"));
        }
    }
    Ok(())
}

//! The LP / QP problem of one cell: its operator, its partners held in boxes, the support function and
//! the closest reachable colour (clarabel).

use super::*;

/// The constraint part of the LPs, assembled once per problem: `A x + s = b`, `s` in the cones.
pub(super) struct Lp {
    a: CscMatrix<f64>,
    b: Vec<f64>,
    cones: Vec<SupportedConeT<f64>>,
}

impl Problem {
    /// The problem of `cell` with the palette's spectra at `values`. `tolerance` is τ in ΔE (≥ 0).
    pub fn new(
        palette: &Palette,
        basis: Option<&Basis>,
        colorimetry: &Colorimetry,
        values: &Values,
        cell: usize,
        tolerance: f64,
    ) -> Result<Problem, FeasibilityError> {
        let c = palette.colours.get(cell).ok_or(FeasibilityError::NoSuchCell(cell))?;
        let label = cell_label(palette, cell);
        let design = Design::new(palette, basis, colorimetry)?;
        let form = if palette.settings.fit_in_subspace { Form::Subspace } else { Form::Full };
        let (ld, rd) = (palette.lights[c.light].design, palette.reflectances[c.reflectance].design);
        if ld == rd {
            let why = if ld {
                "light and reflectance are both designed: the colour is bilinear, not linear, in the unknowns"
            } else {
                "neither side is designed: the colour is fixed (a single point)"
            };
            return Err(FeasibilityError::NotLinear { cell: label, why });
        }
        if !c.is_active() {
            return Err(FeasibilityError::Inactive { cell: label });
        }
        let (unit, current, entry) = if rd {
            (Unit::Reflectance(c.reflectance), values.reflectances[c.reflectance], &palette.reflectances[c.reflectance])
        } else {
            (Unit::Light(c.light), values.lights[c.light], &palette.lights[c.light])
        };
        let bounds = palette.bounds_of(entry);
        // The fixed side of cell `j` of this spectrum.
        let partner_side = |j: usize| {
            let cj = &palette.colours[j];
            if rd { values.lights[cj.light] } else { values.reflectances[cj.reflectance] }
        };
        let op = design.operator(form, &partner_side(cell));
        let achieved = op * current.0;
        let mut partners = Vec::new();
        let mut joint = Vec::new();
        for (j, cj) in palette.colours.iter().enumerate() {
            let same = if rd { cj.reflectance == c.reflectance } else { cj.light == c.light };
            if j == cell || !same || !cj.is_active() {
                continue;
            }
            let other_designed =
                if rd { palette.lights[cj.light].design } else { palette.reflectances[cj.reflectance].design };
            if other_designed {
                joint.push(j);
                continue;
            }
            let opj = design.operator(form, &partner_side(j));
            let colour = opj * current.0;
            let white = colorimetry.reference_white(&values.lights[cj.light]);
            let lab = lab_jacobian(&colorimetry.rgb_to_xyz, &white, &colour);
            let target = cj.free.map(|g| values.free[g]).unwrap_or(cj.target);
            let outer = met_box(&colorimetry.rgb_to_xyz, &white, &target, tolerance.max(0.0));
            partners.push(Partner { cell: j, op: opj, colour, lab, target, outer });
        }
        let target = c.free.map(|g| values.free[g]).unwrap_or(c.target);
        Ok(Problem {
            cell,
            unit,
            op,
            lower: bounds.lower,
            upper: bounds.upper,
            current,
            achieved,
            target,
            white: colorimetry.reference_white(&values.lights[c.light]),
            rgb_to_xyz: colorimetry.rgb_to_xyz,
            partners,
            tolerance: tolerance.max(0.0),
            joint,
            label,
        })
    }

    /// The same problem without partners: what the bounds alone allow.
    pub fn alone(&self) -> Problem {
        Problem { partners: Vec::new(), ..self.clone() }
    }

    /// The same problem without the partner at index `i` of [`Problem::partners`].
    pub(crate) fn without(&self, i: usize) -> Problem {
        let mut p = self.clone();
        if i < p.partners.len() {
            p.partners.remove(i);
        }
        p
    }

    /// The cell's label, "light × reflectance".
    pub fn label(&self) -> &str {
        &self.label
    }

    /// CIELAB of a linear sRGB colour under the cell's light.
    pub fn lab(&self, rgb: &Vector3<f64>) -> [f64; 3] {
        xyz_to_lab(&(self.rgb_to_xyz * rgb), &self.white)
    }

    /// CIEDE2000 between two colours under the cell's light.
    pub fn delta_e(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
        delta_e00(self.lab(a), self.lab(b))
    }

    /// The CIELAB Jacobian at `rgb` under the cell's light.
    pub fn jacobian(&self, rgb: &Vector3<f64>) -> Matrix3<f64> {
        lab_jacobian(&self.rgb_to_xyz, &self.white, rgb)
    }

    /// Half-width of each partner's box per CIELAB component.
    pub fn half_width(&self) -> f64 {
        self.tolerance / 3f64.sqrt()
    }

    /// What the region depends on, as numbers (the cache key).
    pub fn key(&self, directions: usize) -> Vec<u64> {
        let unit = match self.unit {
            Unit::Light(i) => i as u64,
            Unit::Reflectance(i) => (1 << 32) | i as u64,
            Unit::Free(g) => (2 << 32) | g as u64,
        };
        let mut k = vec![unit, self.cell as u64, directions as u64];
        k.extend([self.lower, self.upper, self.tolerance].iter().map(|v| v.to_bits()));
        k.extend(self.op.iter().map(|v| v.to_bits()));
        k.extend(self.achieved.iter().map(|v| v.to_bits()));
        for p in &self.partners {
            k.push(p.cell as u64);
            k.extend(p.op.iter().chain(p.colour.iter()).chain(p.target.iter()).map(|v| v.to_bits()));
        }
        k
    }

    /// The constraints: bounds, partner boxes (or equalities when τ = 0) and optional extra equalities.
    pub(super) fn lp(&self, extra: &[(RowVector3<f64>, f64)]) -> Lp {
        self.lp_held(Hold::Inner, extra, &[])
    }

    /// The constraints with the partners held by `hold`, extra equalities on the cell's colour and extra
    /// inequalities `row · (A_k x) ≤ rhs`.
    pub(super) fn lp_held(
        &self,
        hold: Hold,
        extra: &[(RowVector3<f64>, f64)],
        extra_le: &[(RowVector3<f64>, f64)],
    ) -> Lp {
        // Rows as dense 31-vectors with their right-hand sides: equalities first, then inequalities.
        let mut eq: Vec<([f64; SAMPLES], f64)> = Vec::new();
        let mut le: Vec<([f64; SAMPLES], f64)> = Vec::new();
        for (row, rhs) in extra {
            let r = row * self.op;
            eq.push((std::array::from_fn(|i| r[i]), *rhs));
        }
        for (row, rhs) in extra_le {
            let r = row * self.op;
            le.push((std::array::from_fn(|i| r[i]), *rhs));
        }
        for p in &self.partners {
            let (half, colour, lab) = match hold {
                Hold::Inner => (Vector3::repeat(self.half_width()), p.colour, p.lab),
                Hold::Outer => (p.outer.half, p.target, p.outer.rows),
            };
            if half == Vector3::zeros() {
                for ch in 0..3 {
                    eq.push((std::array::from_fn(|i| p.op[(ch, i)]), colour[ch]));
                }
            } else {
                let m = lab * p.op;
                let centre = lab * colour;
                for ch in 0..3 {
                    if !half[ch].is_finite() {
                        continue;
                    }
                    let row: [f64; SAMPLES] = std::array::from_fn(|i| m[(ch, i)]);
                    le.push((row, centre[ch] + half[ch]));
                    le.push((row.map(|v| -v), -centre[ch] + half[ch]));
                }
            }
        }
        for i in 0..SAMPLES {
            let mut e = [0.0; SAMPLES];
            if self.upper.is_finite() {
                e[i] = 1.0;
                le.push((e, self.upper));
            }
            if self.lower.is_finite() {
                e[i] = -1.0;
                le.push((e, -self.lower));
            }
        }
        let rows: Vec<&([f64; SAMPLES], f64)> = eq.iter().chain(&le).collect();
        let mut colptr = vec![0];
        let mut rowval = Vec::new();
        let mut nzval = Vec::new();
        for col in 0..SAMPLES {
            for (r, (row, _)) in rows.iter().enumerate() {
                if row[col] != 0.0 {
                    rowval.push(r);
                    nzval.push(row[col]);
                }
            }
            colptr.push(rowval.len());
        }
        let mut cones = Vec::new();
        if !eq.is_empty() {
            cones.push(ZeroConeT(eq.len()));
        }
        if !le.is_empty() {
            cones.push(NonnegativeConeT(le.len()));
        }
        Lp {
            a: CscMatrix::new(rows.len(), SAMPLES, colptr, rowval, nzval),
            b: rows.iter().map(|(_, b)| *b).collect(),
            cones,
        }
    }

    /// Minimise `½ xᵀ P x + qᵀ x` under `lp`.
    pub(super) fn run(&self, lp: &Lp, p: &CscMatrix<f64>, q: &[f64]) -> Result<Outcome, FeasibilityError> {
        let settings =
            DefaultSettingsBuilder::default().verbose(false).max_iter(200).build().map_err(|e| {
                FeasibilityError::Solver { cell: self.label.clone(), status: format!("settings: {e:?}") }
            })?;
        if lp.b.is_empty() {
            // No constraint at all (unbounded spectrum, no partner): only a QP with P ≠ 0 has an optimum,
            // and clarabel needs at least one row; x = 0 with a trivially true row.
            let a = CscMatrix::new(1, SAMPLES, vec![0; SAMPLES + 1], Vec::new(), Vec::new());
            let lp1 = Lp { a, b: vec![1.0], cones: vec![NonnegativeConeT(1)] };
            return self.run(&lp1, p, q);
        }
        let mut solver = DefaultSolver::new(p, q, &lp.a, &lp.b, &lp.cones, settings)
            .map_err(|e| FeasibilityError::Solver { cell: self.label.clone(), status: format!("{e:?}") })?;
        solver.solve();
        let s = &solver.solution;
        match s.status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => Ok(Outcome::Optimal(s.x.clone())),
            SolverStatus::DualInfeasible | SolverStatus::AlmostDualInfeasible => Ok(Outcome::Unbounded),
            SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => Ok(Outcome::Infeasible),
            other => Err(FeasibilityError::Solver { cell: self.label.clone(), status: format!("{other:?}") }),
        }
    }

    /// The support value `max d·(A_k x)` and a maximiser's colour; `None` when unbounded in `d`.
    pub(super) fn support_with(&self, lp: &Lp, d: &Vector3<f64>) -> Result<Option<Support>, FeasibilityError> {
        let g = self.op.transpose() * d;
        let q: Vec<f64> = g.iter().map(|v| -v).collect();
        match self.run(lp, &CscMatrix::zeros((SAMPLES, SAMPLES)), &q)? {
            Outcome::Optimal(x) => {
                let x = nalgebra::SVector::<f64, SAMPLES>::from_column_slice(&x);
                let c = self.op * x;
                Ok(Some((d.dot(&c), c)))
            }
            Outcome::Unbounded => Ok(None),
            Outcome::Infeasible => Err(FeasibilityError::Infeasible { cell: self.label.clone() }),
        }
    }

    /// Like [`Problem::support_with`], with infeasibility as `None` instead of an error.
    pub(super) fn support_outcome(
        &self,
        lp: &Lp,
        d: &Vector3<f64>,
    ) -> Result<Option<Option<Support>>, FeasibilityError> {
        match self.support_with(lp, d) {
            Ok(s) => Ok(Some(s)),
            Err(FeasibilityError::Infeasible { .. }) => Ok(None),
            Err(e) => Err(e),
        }
    }

    /// The outer region's support value in direction `d`: `None` when unbounded that way, an
    /// [`FeasibilityError::Infeasible`] error when the outer region is empty.
    pub fn outer_support(&self, d: &Vector3<f64>) -> Result<Option<Support>, FeasibilityError> {
        self.support_with(&self.lp_held(Hold::Outer, &[], &[]), d)
    }

    /// Could the solve's "met" criterion accept `target` at all? True when some x within the bounds
    /// puts the cell in the [`met_box`] of the target (which contains every colour within ΔE00 τ
    /// of it) and every partner in its outer box. False is a
    /// guarantee: no solution has this cell and every partner within ΔE00 τ of their targets.
    pub(crate) fn may_meet(&self, target: &Vector3<f64>) -> Result<bool, FeasibilityError> {
        let b = met_box(&self.rgb_to_xyz, &self.white, target, self.tolerance);
        let centre = b.rows * target;
        let lp = if b.half == Vector3::zeros() {
            let eq: Vec<(RowVector3<f64>, f64)> = (0..3).map(|ch| (b.rows.row(ch).into_owned(), centre[ch])).collect();
            self.lp_held(Hold::Outer, &eq, &[])
        } else {
            let mut le = Vec::with_capacity(6);
            for ch in 0..3 {
                if b.half[ch].is_finite() {
                    let row = b.rows.row(ch).into_owned();
                    le.push((row, centre[ch] + b.half[ch]));
                    le.push((-row, -centre[ch] + b.half[ch]));
                }
            }
            self.lp_held(Hold::Outer, &[], &le)
        };
        let zero = vec![0.0; SAMPLES];
        match self.run(&lp, &CscMatrix::zeros((SAMPLES, SAMPLES)), &zero)? {
            Outcome::Infeasible => Ok(false),
            Outcome::Optimal(_) | Outcome::Unbounded => Ok(true),
        }
    }

    /// The support value in direction `d` (linear sRGB): `None` when the region is unbounded that way.
    pub fn support(&self, d: &Vector3<f64>) -> Result<Option<Support>, FeasibilityError> {
        self.support_with(&self.lp(&[]), d)
    }

    /// The reachable colour closest to `target` in CIELAB linearised at the target, and that distance.
    pub(crate) fn closest(&self, target: &Vector3<f64>) -> Result<(Vector3<f64>, f64), FeasibilityError> {
        let j = self.jacobian(target);
        let m = j * self.op;
        let h = m.transpose() * m * 2.0;
        let mut colptr = vec![0];
        let mut rowval = Vec::new();
        let mut nzval = Vec::new();
        for col in 0..SAMPLES {
            for row in 0..=col {
                rowval.push(row);
                nzval.push(h[(row, col)]);
            }
            colptr.push(rowval.len());
        }
        let p = CscMatrix::new(SAMPLES, SAMPLES, colptr, rowval, nzval);
        let y = j * target;
        let q: Vec<f64> = (m.transpose() * y * -2.0).iter().copied().collect();
        match self.run(&self.lp(&[]), &p, &q)? {
            Outcome::Optimal(x) => {
                let x = nalgebra::SVector::<f64, SAMPLES>::from_column_slice(&x);
                let c = self.op * x;
                Ok((c, (j * (c - target)).norm()))
            }
            Outcome::Unbounded => {
                Err(FeasibilityError::Solver { cell: self.label.clone(), status: "QP unbounded".into() })
            }
            Outcome::Infeasible => Err(FeasibilityError::Infeasible { cell: self.label.clone() }),
        }
    }

    /// Can the cell reach `target` exactly (within the QP's accuracy)?
    pub(crate) fn reaches(&self, target: &Vector3<f64>) -> Result<bool, FeasibilityError> {
        Ok(self.closest(target)?.1 <= REACH_EPS)
    }
}

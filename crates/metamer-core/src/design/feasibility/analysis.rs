//! Per-cell analysis: the region cache, a cell's feasibility, the line for the solve table and the
//! designer's panel.

use super::*;

/// Regions shared between requests with the same problem (see the module docs for the key).
#[derive(Default)]
pub struct RegionCache {
    map: Mutex<HashMap<Vec<u64>, Arc<Region>>>,
}

impl RegionCache {
    /// The region of `problem` with `n` directions, computed once per key.
    pub fn get(&self, problem: &Problem, n: usize) -> Result<Arc<Region>, FeasibilityError> {
        let key = problem.key(n);
        if let Ok(map) = self.map.lock()
            && let Some(r) = map.get(&key)
        {
            return Ok(r.clone());
        }
        let r = Arc::new(region(problem, n)?);
        if let Ok(mut map) = self.map.lock() {
            map.insert(key, r.clone());
        }
        Ok(r)
    }

    /// Number of regions held.
    pub fn len(&self) -> usize {
        self.map.lock().map(|m| m.len()).unwrap_or(0)
    }

    /// True when no region is held.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The feasibility of one cell's target.
#[derive(Clone, Debug)]
pub struct CellFeasibility {
    pub(crate) cell: usize,
    /// Where the target lies against the cell's region, how far from its boundary, and the closest reachable colour.
    pub verdict: Verdict,
    /// Can the bounds alone (no partner held) reach the target?
    pub reachable_alone: bool,
    /// Partner cells that must move for the target to be reached: each one, released alone, makes the
    /// target reachable (empty when the target is reachable, or unreachable even alone, or only when
    /// several partners move together — then [`CellFeasibility::together`] is true).
    pub blockers: Vec<usize>,
    /// Reachable alone, but no single partner's release suffices.
    pub(crate) together: bool,
    /// Active cells on the spectrum not modelled (their other side is designed too).
    pub(crate) joint: Vec<usize>,
    /// The cell's region (shared with the cache).
    pub region: Arc<Region>,
}

/// Analyse one cell: its region (through `cache`), where its target lies, and who blocks it.
pub fn analyse(problem: &Problem, cache: &RegionCache, directions: usize) -> Result<CellFeasibility, FeasibilityError> {
    let region = cache.get(problem, directions)?;
    let verdict = place(problem, &region, &problem.target)?;
    let (reachable_alone, blockers, together) =
        if matches!(verdict.placement, Placement::Outside | Placement::Undecided) {
            let alone = problem.alone().reaches(&problem.target)?;
            let mut blockers = Vec::new();
            if alone {
                for i in 0..problem.partners.len() {
                    if problem.without(i).reaches(&problem.target)? {
                        blockers.push(problem.partners[i].cell);
                    }
                }
            }
            let together = alone && blockers.is_empty();
            (alone, blockers, together)
        } else {
            (true, Vec::new(), false)
        };
    Ok(CellFeasibility {
        cell: problem.cell,
        verdict,
        reachable_alone,
        blockers,
        together,
        joint: problem.joint.clone(),
        region,
    })
}

fn fmt_rgb(c: &Vector3<f64>) -> String {
    use crate::design::report::Fixed;
    format!("[{}, {}, {}]", Fixed(c[0], 4), Fixed(c[1], 4), Fixed(c[2], 4))
}

/// One line about a cell's feasibility, for the solve table.
pub fn describe(palette: &Palette, f: &CellFeasibility, tolerance: f64) -> String {
    use crate::design::report::Fixed;
    let label = cell_label(palette, f.cell);
    let held = format!("the other cells of its spectrum held within ΔE {tolerance}");
    // What keeps an unmet target out of reach (undecided and outside targets); `together` also names the
    // case where only several cells moving at once would help.
    let why_not = |together: bool| -> String {
        if !f.reachable_alone {
            "; out of reach of the bounds even alone".into()
        } else if !f.blockers.is_empty() {
            let names: Vec<String> = f.blockers.iter().map(|&b| cell_label(palette, b)).collect();
            format!("; reachable only if {} moves", names.join(" or "))
        } else if together && f.together {
            "; reachable only if several of the other cells move together".into()
        } else {
            String::new()
        }
    };
    let mut s = match f.verdict.placement {
        Placement::Inside => format!(
            "cell {label}: target reachable with {held} (inside the region, ΔE00 {} from its boundary)",
            Fixed(-f.verdict.signed_delta_e, 2)
        ),
        Placement::On => format!("cell {label}: target on the boundary of what is reachable with {held}"),
        Placement::Undecided => {
            let s = format!(
                "cell {label}: target undecided: ΔE00 {} outside what is reachable with {held}, closest such colour {}, \
                 but not provably out of reach of the solve's ΔE00 {tolerance} criterion",
                Fixed(f.verdict.signed_delta_e, 2),
                fmt_rgb(&f.verdict.closest)
            );
            s + &why_not(false)
        }
        Placement::Outside => {
            let s = format!(
                "cell {label}: target not reachable with {held}: ΔE00 {} outside, closest reachable colour {}",
                Fixed(f.verdict.signed_delta_e, 2),
                fmt_rgb(&f.verdict.closest)
            );
            s + &why_not(true)
        }
    };
    let r = &f.region;
    s += &format!(
        " [region L* {}…{}, volume {} ΔE³]",
        Fixed(r.l_range.0, 1),
        Fixed(r.l_range.1, 1),
        if r.volume_lab.is_finite() { format!("{}", Fixed(r.volume_lab, 1)) } else { "unbounded".into() }
    );
    if !f.joint.is_empty() {
        let names: Vec<String> = f.joint.iter().map(|&b| cell_label(palette, b)).collect();
        s += &format!(" (not held: {}, designed jointly)", names.join(", "));
    }
    s
}

/// What the designer draws for one cell: the region's slice at the target's L*, the marks, the numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    pub(crate) cell: usize,
    /// "light × reflectance".
    pub label: String,
    /// The tolerance τ the partners are held to, ΔE.
    pub tolerance: f64,
    /// The slice at the target's L* (`None` when the region does not reach it).
    pub slice: Option<Slice>,
    /// The outer region's slice at the same L* (`None` when it does not reach it or is empty).
    pub outer_slice: Option<Slice>,
    /// The target in CIELAB (L*, a*, b*) under the cell's light.
    pub target_lab: [f64; 3],
    /// The cell's current colour in CIELAB (L*, a*, b*) under the cell's light.
    pub achieved_lab: [f64; 3],
    /// The lowest and highest L* the inner region reaches under the cell's light (`±∞` where unbounded).
    pub l_range: (f64, f64),
    /// Where the target lies against the regions (inside, on, undecided, outside).
    pub placement: Placement,
    /// ΔE00 from the target to the inner region's boundary: negative inside, positive outside.
    pub signed_delta_e: f64,
    pub(crate) volume_lab: f64,
    /// Partner cells held.
    pub held: usize,
}

/// The [`Panel`] of `cell` with the palette's spectra at `values` (through `cache`).
pub fn panel(
    palette: &Palette,
    basis: Option<&Basis>,
    colorimetry: &Colorimetry,
    values: &Values,
    cell: usize,
    tolerance: f64,
    cache: &RegionCache,
) -> Result<Panel, FeasibilityError> {
    let problem = Problem::new(palette, basis, colorimetry, values, cell, tolerance)?;
    let region = cache.get(&problem, DEFAULT_DIRECTIONS)?;
    let verdict = place(&problem, &region, &problem.target)?;
    let target_lab = problem.lab(&problem.target);
    let slice = slice(&problem, target_lab[0], &problem.target, SLICE_DIRECTIONS)?;
    let outer_slice = if region.outer_empty {
        None
    } else {
        slice_held(&problem, Hold::Outer, target_lab[0], &problem.target, SLICE_DIRECTIONS)?
    };
    Ok(Panel {
        cell,
        label: problem.label().to_string(),
        tolerance,
        slice,
        outer_slice,
        target_lab,
        achieved_lab: problem.lab(&problem.achieved),
        l_range: region.l_range,
        placement: verdict.placement,
        signed_delta_e: verdict.signed_delta_e,
        volume_lab: region.volume_lab,
        held: problem.partners.len(),
    })
}

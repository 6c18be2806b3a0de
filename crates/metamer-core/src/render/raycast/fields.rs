//! Per-brick fields the marcher samples besides the raw values, built on demand and bounded: a brick's
//! block is computed the first time a ray needs it (under its slot's lock, so each resident block is
//! built once whichever thread gets there first, and its contents depend only on the volume and the
//! transfer function). Rays stop at the first opaque surface and skip empty bricks, so only the bricks
//! rays actually reach are built — a fraction of the volume — instead of a whole-volume grid per
//! raycast. A thin transfer function lets rays reach every brick, so the resident blocks are capped
//! ([`default_field_cache`]: half the voxels' bytes, at least 64 MiB; `RaycastOptions::field_cache`) and
//! others are evicted; a block needed again is rebuilt, identical, so frames are byte-identical whatever
//! the cap (`tests.rs` checks it with a cap that evicts almost everything). While blocks may be evicted
//! the raycast traces bands of tile rows one after another (`super::Bands`, their height from the mean
//! size of the blocks built so far, [`Fields::room_now`]), and the block evicted
//! first is the one whose last pixel row (the lowest row of the image its brick projects onto) comes
//! soonest: one the rays have passed, never needed again, while there is one. When the largest block
//! times the bricks a raycast can reach fits the cap,
//! nothing can be evicted: each block is then built once into a per-brick `OnceLock` and rays read it
//! without a lock or a reference count (the pinned store; `tests.rs` compares it with the capped one).
//!
//! A block covers the `BRICK + 1` voxels per axis of one 8³ brick plus the one-voxel seam to its
//! upper neighbours, so every trilinear cell that starts in the brick finds its eight corners in it.
//! It holds:
//! - **the smooth gradient** (`i16` triples, 6 bytes an entry): central differences of the field
//!   shading normals come from, `h` voxels either side. Shifting a trilinear interpolant by whole
//!   voxels keeps the sample's fractional position, so the trilinear interpolation of these is the
//!   central difference of the interpolated field (the same normal as six interpolated lookups, for one
//!   cell fetch). The field is the value (trilinear mode, `h` = 1) or the step-corrected opacity
//!   (nearest mode, `h` = 2).
//! - **label fields** (label mode): per material present, the shape-based signed distance of
//!   `labels` (see there, `u16`) and its gradient, one `i16` triple per material and entry; a block
//!   classifies the voxels around it by the transfer function's table as it is built.

use super::block::{FIELD_BRICK, S, S3, SHIFT};
use super::classify::Classifier;
use super::labels;
use crate::region::{Buf, Region};
use crate::volume::Volume;
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::ops::Deref;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock, PoisonError};

const BRICK: usize = FIELD_BRICK;

/// The least cap of the resident blocks (within the 160 MiB that [`crate::memory::render_estimate`] gives
/// besides the voxels and their half): a small volume keeps all the blocks its rays reach.
pub const MIN_FIELD_CACHE: u64 = 64 * crate::memory::MIB;

/// The default cap of the resident field blocks for a volume of `voxel_bytes`: half its voxels (the
/// derived-field share of [`crate::memory::render_estimate`]), at least [`MIN_FIELD_CACHE`].
pub fn default_field_cache(voxel_bytes: u64) -> u64 {
    (voxel_bytes / 2).max(MIN_FIELD_CACHE)
}

/// Field bricks per axis of `volume`.
fn brick_counts(volume: &Volume) -> [usize; 3] {
    volume.dims.map(|n| n.div_ceil(BRICK).max(1))
}

/// Field bricks of `volume`.
pub(super) fn brick_count(volume: &Volume) -> usize {
    brick_counts(volume).iter().product()
}

/// What a [`Fields`] holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    /// Gradient of the values (trilinear sampling).
    Values,
    /// Gradient of the step-corrected opacity, two voxels either side (nearest sampling).
    Opacity,
    /// Per material, the shape-based signed distance and its gradient.
    Labels,
}

/// One brick's block.
pub(super) struct Block {
    /// `S3` gradient triples, per material in label mode (empty when no gradients are needed); a value
    /// block's are followed by a padding entry ([`Fields::gradient`]).
    /// In the pinned store's [`Region`] when it has one (value and opacity blocks), else on the heap.
    pub(crate) grad: Buf<[i16; 3]>,
    /// Materials (0-based) with some occupancy in the block (label mode).
    pub(crate) mats: Vec<u8>,
    /// `mats.len() × S3` signed distances (label mode, [`labels::LabelBlock::sdf`]).
    pub(crate) sdf: Vec<u16>,
}

impl Block {
    /// Heap and header bytes.
    fn bytes(&self) -> u64 {
        (self.grad.len() * 6 + self.sdf.len() * 2 + self.mats.len() + std::mem::size_of::<Block>()) as u64
    }
}

/// One brick's place in the cache: its block while resident.
struct Slot {
    block: Mutex<Option<Arc<Block>>>,
}

/// A ray's hold on the block it is in: rays stay in a brick for several samples, so the cache is asked
/// once per brick a ray enters, and the block stays alive for the ray even when the cache evicts it.
#[derive(Default)]
pub(super) struct Cursor<'a> {
    brick: usize,
    block: Option<BlockRef<'a>>,
}

impl Cursor<'_> {
    /// The block of the brick the cursor was last moved to ([`Fields::block`]), with that brick's index.
    #[inline(always)]
    pub(super) fn held(&self) -> Option<(&Block, usize)> {
        self.block.as_deref().map(|b| (b, self.brick))
    }
}

/// A block as a ray holds it: borrowed from a [`Fields`] that never evicts (no reference count to
/// touch, so threads sharing a block share no written cache line), or counted while evictions may
/// drop it from the cache.
#[derive(Clone)]
pub(super) enum BlockRef<'a> {
    Pinned(&'a Block),
    Held(Arc<Block>),
}

impl Deref for BlockRef<'_> {
    type Target = Block;
    #[inline(always)]
    fn deref(&self) -> &Block {
        match self {
            BlockRef::Pinned(b) => b,
            BlockRef::Held(b) => b,
        }
    }
}

/// Where the blocks live.
enum Store {
    /// Every block the raycast can build fits within the cap: each built once (under its cell's
    /// once-lock: a thread wanting the same brick waits for it), never evicted, read without a lock.
    Pinned(Vec<OnceLock<Block>>),
    /// Capped with eviction: per brick a slot; the resident bricks keyed by the last pixel row whose
    /// rays can reach them (`Fields::last_rows`), the soonest passed evicted first.
    Capped { slots: Vec<Slot>, resident: Mutex<BinaryHeap<Reverse<(u32, u32)>>> },
}

/// Counters of a [`Fields`] after a raycast.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Usage {
    /// Blocks built (a block evicted and needed again is built again, and counted again).
    pub(super) built: u64,
    /// Their bytes.
    pub(super) built_bytes: u64,
    /// Blocks evicted to keep the resident bytes within the cap.
    pub(super) evicted: u64,
    /// The cap, and the most bytes resident at once (blocks and the per-brick slots).
    pub(super) cap: u64,
    pub(super) peak: u64,
}

/// The per-brick blocks of one raycast, built on demand and bounded: at most `cap` bytes of blocks are
/// resident (beyond those the running rays hold, one per thread), those whose rays end soonest evicted
/// first ([`Fields::evict_by_rows`]). An evicted block needed again is rebuilt — identical, since it depends only on the volume
/// and the transfer function — so frames are the same whatever the cap.
pub(super) struct Fields<'a> {
    volume: &'a Volume,
    classifier: &'a Classifier,
    kind: Kind,
    gradients: bool,
    counts: [usize; 3],
    store: Store,
    cap: u64,
    resident: AtomicU64,
    peak: AtomicU64,
    /// Field units per stored gradient unit.
    pub(crate) scale: f32,
    /// Build gradient blocks with the AVX2 build (set only where the processor has it; the same blocks).
    pub(super) avx2: bool,
    /// The capped store's room in blocks of the largest size (None: pinned, nothing is evicted).
    room: Option<u64>,
    /// The capped store's bytes for blocks (the cap less the slots).
    room_bytes: u64,
    /// Capped store: per brick, the last pixel row whose ray can reach it. The raycast traces its rows of
    /// tiles in turn, so a block whose last row is above the rows being traced is never needed again.
    /// Empty: evicted in the order built.
    last_rows: Vec<u32>,
    /// Blocks admitted so far (the eviction order without `last_rows`).
    admitted: AtomicU64,
    /// The pinned store's gradient blocks, one after another in one mapping of huge pages (never freed
    /// before the store, so nothing is lost by not freeing them one by one): a raycast's first touches of
    /// its blocks' memory take a few 2 MiB faults instead of one 4 KiB fault per page and a malloc per
    /// block. None: capped store, label blocks, or no mapping (the heap then).
    region: Option<Arc<Region>>,
    built_bytes: AtomicU64,
    built: AtomicU64,
    evicted: AtomicU64,
}

impl<'a> Fields<'a> {
    /// `cap`: the most bytes of blocks kept resident; `reachable`: how many bricks can have their block
    /// built (None: any). When the largest block times `reachable` fits the cap, blocks are never
    /// evicted and are read without locks or reference counts.
    pub fn new(
        volume: &'a Volume,
        classifier: &'a Classifier,
        kind: Kind,
        gradients: bool,
        cap: u64,
        reachable: Option<usize>,
    ) -> Fields<'a> {
        let counts = brick_counts(volume);
        let n = brick_count(volume);
        let (h, span) = match kind {
            Kind::Values => (1.0f32, (volume.value_range[1] - volume.value_range[0]).abs()),
            Kind::Opacity | Kind::Labels => (2.0, 1.0),
        };
        // A central difference is at most the field's span over 2h.
        let bound = span / (2.0 * h);
        let scale = match kind {
            Kind::Labels => labels::GRAD_SCALE,
            _ if bound > 0.0 && bound.is_finite() => bound / f32::from(i16::MAX),
            _ => 1.0,
        };
        // The largest block: per material present (all of them in label mode) its distances and
        // gradients, or one gradient grid.
        let per_entry = match kind {
            Kind::Labels => classifier.materials * (2 + if gradients { 6 } else { 0 }),
            Kind::Values | Kind::Opacity => 6,
        };
        // A value block's gradients end with a padding entry ([`Fields::gradient`]).
        let padding = if kind == Kind::Labels { 0 } else { 6 };
        let largest = (S3 * per_entry + padding + classifier.materials + std::mem::size_of::<Block>()) as u64;
        let pinned_bytes = (n * std::mem::size_of::<OnceLock<Block>>()) as u64;
        let reach = reachable.unwrap_or(n).min(n) as u64;
        let pinned = largest.saturating_mul(reach).saturating_add(pinned_bytes) <= cap;
        // Room for every block the raycast can build (each is built once when pinned); only the pages
        // touched become resident.
        let region = (pinned && kind != Kind::Labels).then(|| Region::new((S3 + 1) * 6 * reach as usize)).flatten();
        let (store, slot_bytes, room) = if pinned {
            (Store::Pinned((0..n).map(|_| OnceLock::new()).collect()), pinned_bytes, None)
        } else {
            let slots = (0..n).map(|_| Slot { block: Mutex::new(None) }).collect();
            let slot_bytes = (n * (std::mem::size_of::<Slot>() + std::mem::size_of::<u32>())) as u64;
            (
                Store::Capped { slots, resident: Mutex::new(BinaryHeap::new()) },
                slot_bytes,
                Some(cap.saturating_sub(slot_bytes) / largest),
            )
        };
        Fields {
            volume,
            classifier,
            kind,
            gradients,
            counts,
            store,
            cap,
            resident: AtomicU64::new(slot_bytes),
            peak: AtomicU64::new(slot_bytes),
            scale,
            avx2: false,
            room,
            room_bytes: cap.saturating_sub(slot_bytes),
            last_rows: Vec::new(),
            admitted: AtomicU64::new(0),
            region,
            built_bytes: AtomicU64::new(0),
            built: AtomicU64::new(0),
            evicted: AtomicU64::new(0),
        }
    }

    /// How many blocks the cap holds when blocks may be evicted (None: every block the raycast can build
    /// fits, none is evicted). The raycast orders its rays by it ([`super::Bands`]).
    pub(super) fn room(&self) -> Option<u64> {
        self.room
    }

    /// How many blocks of the mean size built so far the cap holds (before any is built, or pinned:
    /// [`Self::room`]'s blocks of the largest size). The label blocks of a scene are far smaller than the
    /// largest (every material in reach of every entry): the frog's average 2.9 KB against 32 KB.
    pub(super) fn room_now(&self) -> u64 {
        let room = self.room.unwrap_or(u64::MAX);
        let built = self.built.load(Ordering::Relaxed);
        if built == 0 {
            return room;
        }
        let mean = (self.built_bytes.load(Ordering::Relaxed) / built).max(1);
        (self.room_bytes / mean).max(room)
    }

    /// Capped store: evict by `last_rows` (per field brick in x-fastest order, the last pixel row whose
    /// ray can reach it), the block whose rays end soonest first; a block whose rays are all traced is
    /// never needed again. Only the time depends on it, never the frame.
    pub(super) fn evict_by_rows(&mut self, last_rows: Vec<u32>) {
        debug_assert_eq!(last_rows.len(), brick_count(self.volume));
        self.last_rows = last_rows;
    }

    /// Field bricks per axis.
    pub(super) fn counts(&self) -> [usize; 3] {
        self.counts
    }

    /// What the cache did.
    pub(super) fn usage(&self) -> Usage {
        Usage {
            built: self.built.load(Ordering::Relaxed),
            built_bytes: self.built_bytes.load(Ordering::Relaxed),
            evicted: self.evicted.load(Ordering::Relaxed),
            cap: self.cap,
            peak: self.peak.load(Ordering::Relaxed),
        }
    }

    /// The brick holding cell start `i`.
    #[inline(always)]
    pub(crate) fn brick_of(&self, i: [usize; 3]) -> [usize; 3] {
        // Written out: `[0, 1, 2].map` is not always inlined, and this runs at every shaded sample.
        let c = &self.counts;
        [(i[0] >> SHIFT).min(c[0] - 1), (i[1] >> SHIFT).min(c[1] - 1), (i[2] >> SHIFT).min(c[2] - 1)]
    }

    /// The block of the brick holding cell start `i` (held by the ray's `cursor`), and the local index of
    /// `i` in it.
    #[inline(always)]
    pub(crate) fn block<'c>(&'a self, i: [usize; 3], cursor: &'c mut Cursor<'a>) -> (&'c BlockRef<'a>, usize) {
        let b = self.brick_of(i);
        let l = [i[0] - (b[0] << SHIFT), i[1] - (b[1] << SHIFT), i[2] - (b[2] << SHIFT)];
        let bi = b[0] + self.counts[0] * (b[1] + self.counts[1] * b[2]);
        let local = l[0] + S * (l[1] + S * l[2]);
        if cursor.brick != bi || cursor.block.is_none() {
            cursor.block = Some(self.fetch(bi, b));
            cursor.brick = bi;
        }
        match &cursor.block {
            Some(block) => (block, local),
            None => unreachable!("the cursor was just filled"),
        }
    }

    /// The resident block of brick `bi` (at `b`), built when it is not.
    #[inline]
    fn fetch(&'a self, bi: usize, b: [usize; 3]) -> BlockRef<'a> {
        match &self.store {
            Store::Pinned(cells) => BlockRef::Pinned(cells[bi].get_or_init(|| self.build_counted(b))),
            Store::Capped { slots, resident } => BlockRef::Held(self.fetch_capped(slots, resident, bi, b)),
        }
    }

    /// A new block of brick `b`, counted as built and resident.
    #[cold]
    fn build_counted(&self, b: [usize; 3]) -> Block {
        let block = self.build(b);
        let bytes = self.count_built(&block);
        let resident = self.resident.fetch_add(bytes, Ordering::Relaxed) + bytes;
        self.peak.fetch_max(resident, Ordering::Relaxed);
        block
    }

    /// Count `block` as built (both stores); its bytes.
    fn count_built(&self, block: &Block) -> u64 {
        let bytes = block.bytes();
        self.built_bytes.fetch_add(bytes, Ordering::Relaxed);
        self.built.fetch_add(1, Ordering::Relaxed);
        bytes
    }

    /// [`Self::fetch`] from the capped store.
    #[cold]
    fn fetch_capped(
        &self,
        slots: &[Slot],
        resident: &Mutex<BinaryHeap<Reverse<(u32, u32)>>>,
        bi: usize,
        b: [usize; 3],
    ) -> Arc<Block> {
        let slot = &slots[bi];
        // A panic while a slot was locked (building its block) leaves it empty or whole: either is valid.
        let mut held = slot.block.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(block) = &*held {
            return Arc::clone(block);
        }
        // Built under the slot's lock: a thread that wants the same brick waits for it rather than building it
        // twice.
        let block = Arc::new(self.build(b));
        *held = Some(Arc::clone(&block));
        drop(held);
        let bytes = self.count_built(&block);
        self.admit(slots, resident, bi, bytes);
        block
    }

    /// Count a newly built block of brick `bi` as resident, evicting others while the cap is exceeded: the
    /// one whose rays end soonest first (with the bands of tile rows traced in turn, those above the rows being
    /// traced are never needed again), else the oldest.
    fn admit(&self, slots: &[Slot], resident: &Mutex<BinaryHeap<Reverse<(u32, u32)>>>, bi: usize, bytes: u64) {
        let mut heap = resident.lock().unwrap_or_else(PoisonError::into_inner);
        let key = match self.last_rows.get(bi) {
            Some(&row) => row,
            None => self.admitted.fetch_add(1, Ordering::Relaxed).min(u64::from(u32::MAX)) as u32,
        };
        let mut total = self.resident.fetch_add(bytes, Ordering::Relaxed) + bytes;
        while total > self.cap && !heap.is_empty() {
            let Some(Reverse((_, j))) = heap.pop() else { break };
            let gone = slots[j as usize].block.lock().unwrap_or_else(PoisonError::into_inner).take();
            if let Some(g) = gone {
                total = self.resident.fetch_sub(g.bytes(), Ordering::Relaxed) - g.bytes();
                self.evicted.fetch_add(1, Ordering::Relaxed);
            }
        }
        // The new block is admitted last, so it is never the one evicted for itself.
        heap.push(Reverse((key, bi as u32)));
        self.peak.fetch_max(total, Ordering::Relaxed);
    }

    fn build(&self, b: [usize; 3]) -> Block {
        match self.kind {
            Kind::Values | Kind::Opacity => {
                // S3 entries and the (zero) padding entry [`Self::gradient`] reads one component of.
                let mut grad = Buf::zeroed(self.region.as_ref(), S3 + 1);
                self.build_gradient_into(b, &mut grad[..S3]);
                Block { grad, mats: vec![], sdf: vec![] }
            }
            Kind::Labels => {
                let l = labels::build(self.volume, self.classifier, b, self.gradients);
                Block { grad: l.grad.into(), mats: l.mats, sdf: l.sdf }
            }
        }
    }

    /// The trilinear interpolation of the block's gradients at local index `base` and fractions `f`
    /// (field units per voxel).
    #[inline(always)]
    pub(crate) fn gradient(&self, block: &Block, base: usize, f: [f32; 3]) -> [f32; 3] {
        // The cell's corners in one slice of components: one bounds check instead of eight. It reaches one
        // component past the last corner's triple (value blocks hold a padding entry for it), so that each
        // corner is read as four lanes in one load: its triple and the next entry's first component, a
        // lane whose interpolation is discarded.
        let flat = block.grad.as_flattened();
        let Some(g) = flat.get(3 * base..3 * (base + CELL) + 1) else {
            return self.gradient_unpadded(block, base, f);
        };
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{
                __m128, _mm_add_ps, _mm_cvtepi32_ps, _mm_cvtsi64_si128, _mm_mul_ps, _mm_set1_ps, _mm_srai_epi32,
                _mm_storeu_ps, _mm_sub_ps, _mm_unpacklo_epi16,
            };
            // SSE2 (x86-64's baseline) spelled out: without SSE4.1's widening load the compiler widened the
            // four lanes one by one. A corner's four components as one 64-bit word (one load), widened to
            // 32 bits by interleaving with themselves and shifting back, converted to f32.
            let corner = |c: usize| {
                let s = &g[3 * CORNERS[c]..][..4];
                // SAFETY: `s` holds four i16, the eight bytes read (x86-64 reads unaligned words).
                let w = unsafe { s.as_ptr().cast::<u64>().read_unaligned() };
                // SAFETY (here and below): SSE2 is part of x86-64's baseline, so its intrinsics run on any
                // x86-64 processor; these read and write registers only.
                unsafe {
                    let v = _mm_cvtsi64_si128(w as i64);
                    _mm_cvtepi32_ps(_mm_srai_epi32(_mm_unpacklo_epi16(v, v), 16))
                }
            };
            let lerp = |a: __m128, b: __m128, t: __m128| unsafe { _mm_add_ps(a, _mm_mul_ps(t, _mm_sub_ps(b, a))) };
            let [fx, fy, fz] = f.map(|t| unsafe { _mm_set1_ps(t) });
            let c0 = lerp(lerp(corner(0), corner(1), fx), lerp(corner(2), corner(3), fx), fy);
            let c1 = lerp(lerp(corner(4), corner(5), fx), lerp(corner(6), corner(7), fx), fy);
            let mut out = [0f32; 4];
            // SAFETY: `out` holds four f32, the bytes an unaligned store of one __m128 writes.
            unsafe { _mm_storeu_ps(out.as_mut_ptr(), lerp(c0, c1, fz)) };
            [out[0] * self.scale, out[1] * self.scale, out[2] * self.scale]
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let corner = |c: usize| {
                let v: [i16; 4] = g[3 * CORNERS[c]..][..4].try_into().unwrap_or([0; 4]);
                v.map(|q| i32::from(q) as f32)
            };
            self.interpolate(corner, f)
        }
    }

    /// [`Self::gradient`] where the cell's last corner is the block's last entry, without a padding
    /// entry after it (label blocks): each corner as four lanes, the fourth zero.
    #[cold]
    fn gradient_unpadded(&self, block: &Block, base: usize, f: [f32; 3]) -> [f32; 3] {
        let Some(g) = block.grad.get(base..base + CELL) else { return [0.0; 3] };
        let corner = |c: usize| {
            let v = g[CORNERS[c]];
            [i32::from(v[0]), i32::from(v[1]), i32::from(v[2]), 0].map(|q| q as f32)
        };
        self.interpolate(corner, f)
    }

    /// The eight `corner`s (four lanes, the first three the gradient's) interpolated by seven lerps along
    /// x, then y, then z (as `Cell::value` does for one lane): vector operations, and no corner weights
    /// to form.
    #[inline(always)]
    fn interpolate(&self, corner: impl Fn(usize) -> [f32; 4], f: [f32; 3]) -> [f32; 3] {
        let lerp = |a: [f32; 4], b: [f32; 4], t: f32| {
            let mut r = [0f32; 4];
            for l in 0..4 {
                r[l] = a[l] + t * (b[l] - a[l]);
            }
            r
        };
        let [fx, fy, fz] = f;
        let c0 = lerp(lerp(corner(0), corner(1), fx), lerp(corner(2), corner(3), fx), fy);
        let c1 = lerp(lerp(corner(4), corner(5), fx), lerp(corner(6), corner(7), fx), fy);
        let out = lerp(c0, c1, fz);
        [out[0] * self.scale, out[1] * self.scale, out[2] * self.scale]
    }

    /// Central differences of the value (or opacity) field, exactly as a whole-volume grid would hold
    /// them (neighbours clamped into the grid).
    /// Into `grad` (`S3` entries, zeroed).
    fn build_gradient_into(&self, b: [usize; 3], grad: &mut [[i16; 3]]) {
        crate::with_voxels!(&self.volume.voxels, data => {
            #[cfg(target_arch = "x86_64")]
            if self.avx2 {
                // SAFETY: `avx2` is set only where AVX2 was detected (`super::lanes::detected`).
                return unsafe { self.gradient_block_avx2(data, b, grad) };
            }
            self.gradient_block(data, b, grad)
        })
    }

    /// [`Self::build_gradient_into`] a new vector.
    #[cfg(test)]
    fn build_gradient(&self, b: [usize; 3]) -> Vec<[i16; 3]> {
        let mut grad = vec![[0; 3]; S3];
        self.build_gradient_into(b, &mut grad);
        grad
    }

    /// [`Self::gradient_block`] compiled for AVX2: the same operations on each entry (no fused
    /// multiply-add), its loops vectorised eight lanes wide instead of four, so the same block.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn gradient_block_avx2<T: crate::volume::Voxel>(&self, data: &[T], b: [usize; 3], grad: &mut [[i16; 3]]) {
        self.gradient_block(data, b, grad)
    }

    #[inline(always)]
    /// Every one of `grad`'s `S3` entries written.
    fn gradient_block<T: crate::volume::Voxel>(&self, data: &[T], b: [usize; 3], grad: &mut [[i16; 3]]) {
        let d = self.volume.dims;
        let opacity = self.kind == Kind::Opacity;
        let h = if opacity { 2 } else { 1 };
        let den = 2.0 * h as f32;
        let inv = 1.0 / self.scale;
        let max = f32::from(i16::MAX);
        // One quantised central difference from the field `hi` and `lo`, h voxels after and before (both
        // paths below use it).
        // Clamped by comparisons (NaN passes, as through `clamp`, and rounds to 0).
        let diff = |hi: f32, lo: f32| {
            let c = (hi - lo) / den * inv;
            let c = if c < -max { -max } else { c };
            round_half_away(if c > max { max } else { c }) as i16
        };
        let o = b.map(|v| v << SHIFT);
        // The field over the block grown by h each side (coordinates clamped into the grid), read once:
        // entry j along an axis is voxel clamp(o − h + j).
        let n = S + 2 * h;
        let coord = |a: usize, j: usize| (o[a] + j).saturating_sub(h).min(d[a] - 1);
        // A block whose grown extent lies inside the grid on an axis needs no clamping on it.
        let inside = [0, 1, 2].map(|a| o[a] >= h && o[a] + BRICK + h < d[a]);
        // At most S + 4 entries (h ≤ 2): on the stack.
        let mut xs = [0usize; S + 4];
        for (x, c) in xs[..n].iter_mut().enumerate() {
            *c = coord(0, x);
        }
        let conv = |v: T| {
            let v = v.to_f32();
            if opacity { self.classifier.alpha_of(v) } else { v }
        };
        // On the stack (n ≤ S + 4): a block is built for most bricks rays reach, and an allocation per
        // block cost as much as filling it.
        let mut field = [0f32; (S + 4) * (S + 4) * (S + 4)];
        for z in 0..n {
            let vz = coord(2, z);
            for y in 0..n {
                let row = d[0] * (coord(1, y) + d[1] * vz);
                let dst = &mut field[n * (y + n * z)..][..n];
                if inside[0] {
                    for (f, &v) in dst.iter_mut().zip(&data[row + o[0] - h..][..n]) {
                        *f = conv(v);
                    }
                } else {
                    for (f, &x) in dst.iter_mut().zip(&xs[..n]) {
                        *f = conv(data[row + x]);
                    }
                }
            }
        }
        let grad = &mut grad[..S3];
        if inside.iter().all(|&i| i) {
            // No clamping: the neighbours of entry l are the grown field's entries l ± h along each axis,
            // the same values the clamped lookups below read.
            for lz in 0..S {
                for ly in 0..S {
                    // The grown entry h before (lx = 0, ly, lz) along x.
                    let base = n * (ly + h) + n * n * (lz + h);
                    let xm = &field[base..][..S];
                    let xp = &field[base + 2 * h..][..S];
                    let ym = &field[base + h - h * n..][..S];
                    let yp = &field[base + h + h * n..][..S];
                    let zm = &field[base + h - h * n * n..][..S];
                    let zp = &field[base + h + h * n * n..][..S];
                    // Each component along the row on its own (loops the compiler vectorises), then
                    // interleaved.
                    let (mut gx, mut gy, mut gz) = ([0i16; S], [0i16; S], [0i16; S]);
                    for lx in 0..S {
                        gx[lx] = diff(xp[lx], xm[lx]);
                    }
                    for lx in 0..S {
                        gy[lx] = diff(yp[lx], ym[lx]);
                    }
                    for lx in 0..S {
                        gz[lx] = diff(zp[lx], zm[lx]);
                    }
                    let out = &mut grad[S * (ly + S * lz)..][..S];
                    for lx in 0..S {
                        out[lx] = [gx[lx], gy[lx], gz[lx]];
                    }
                }
            }
            return;
        }
        // The field at grid coordinate c (c within the grown block).
        let at = |c: [usize; 3]| field[(c[0] + h - o[0]) + n * ((c[1] + h - o[1]) + n * (c[2] + h - o[2]))];
        for lz in 0..S {
            let z = (o[2] + lz).min(d[2] - 1);
            let (z0, z1) = (z.saturating_sub(h), (z + h).min(d[2] - 1));
            for ly in 0..S {
                let y = (o[1] + ly).min(d[1] - 1);
                let (y0, y1) = (y.saturating_sub(h), (y + h).min(d[1] - 1));
                for lx in 0..S {
                    let x = (o[0] + lx).min(d[0] - 1);
                    let (x0, x1) = (x.saturating_sub(h), (x + h).min(d[0] - 1));
                    grad[lx + S * (ly + S * lz)] = [
                        diff(at([x1, y, z]), at([x0, y, z])),
                        diff(at([x, y1, z]), at([x, y0, z])),
                        diff(at([x, y, z1]), at([x, y, z0])),
                    ];
                }
            }
        }
    }
}

/// `c.round()` (half away from zero) without the library call `round` is on x86-64's baseline, for
/// |c| ≤ 32767 or NaN (0, as `NaN as i32` gives): the fraction `c − trunc(c)` is exact there. The
/// callers clamp to ±32767 first; the truncation is then the plain conversion instruction instead of
/// the saturating `as` (a range and NaN test per entry: a quarter of a gradient block's build).
#[inline(always)]
pub(super) fn round_half_away(c: f32) -> i32 {
    debug_assert!(c.is_nan() || c.abs() <= 32767.0, "{c}");
    // NaN (0 · ∞ where a field's span underflows) becomes 0, as the saturating cast made it.
    let c = if c.is_nan() { 0.0 } else { c };
    // SAFETY: c is finite and |c| ≤ 32767 (clamped by the caller, NaN replaced above), in range for i32.
    let t = unsafe { c.to_int_unchecked::<i32>() };
    let frac = c - t as f32;
    t + i32::from(frac >= 0.5) - i32::from(frac <= -0.5)
}

/// Trilinear weights of the eight corners (`x + 2y + 4z`) at fractions `f`.
#[inline(always)]
pub(super) fn corner_weights(f: [f32; 3]) -> [f32; 8] {
    let [fx, fy, fz] = f;
    [
        (1.0 - fx) * (1.0 - fy) * (1.0 - fz),
        fx * (1.0 - fy) * (1.0 - fz),
        (1.0 - fx) * fy * (1.0 - fz),
        fx * fy * (1.0 - fz),
        (1.0 - fx) * (1.0 - fy) * fz,
        fx * (1.0 - fy) * fz,
        (1.0 - fx) * fy * fz,
        fx * fy * fz,
    ]
}

/// Local offsets of the eight corners of a block cell (`x + 2y + 4z`).
pub(super) const CORNERS: [usize; 8] = [0, 1, S, S + 1, S * S, S * S + 1, S * S + S, S * S + S + 1];
/// Entries from a block cell's first corner to its last, inclusive.
pub(super) const CELL: usize = S * S + S + 2;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::raycast::MaterialClass;

    /// Every brick's gradient block (interior ones by direct offsets, edge ones by clamped lookups) is the
    /// quantised central difference computed straight from the voxels with clamped neighbours.
    #[test]
    fn gradient_blocks_are_the_clamped_central_differences_of_the_voxels() {
        // 21 × 30 × 27: interior bricks on every axis, and edge bricks whose seam lies past the grid.
        let vol = crate::volume::generate::engine_like_u16([21, 30, 27]);
        let mats = [MaterialClass::new([18.0 * 257.0, 75.0 * 257.0], 0.3), MaterialClass::new([2e4, 6e4], 0.8)];
        let classifier = Classifier::new(&vol, &mats, 0.5, 1);
        let d = vol.dims;
        let mut interior = 0;
        for kind in [Kind::Values, Kind::Opacity] {
            let fields = Fields::new(&vol, &classifier, kind, true, u64::MAX, None);
            let h = if kind == Kind::Opacity { 2 } else { 1 };
            let f = |p: [usize; 3]| {
                let v = vol.at(p[0], p[1], p[2]);
                if kind == Kind::Opacity { classifier.alpha_of(v) } else { v }
            };
            for bz in 0..fields.counts[2] {
                for by in 0..fields.counts[1] {
                    for bx in 0..fields.counts[0] {
                        let b = [bx, by, bz];
                        let o = b.map(|v| v << SHIFT);
                        interior += usize::from((0..3).all(|a| o[a] >= h && o[a] + BRICK + h < d[a]));
                        let grad = fields.build_gradient(b);
                        for (l, got) in grad.iter().enumerate() {
                            let lc = [l % S, (l / S) % S, l / (S * S)];
                            let p = [0, 1, 2].map(|a| (o[a] + lc[a]).min(d[a] - 1));
                            let want = [0, 1, 2].map(|a| {
                                let (mut lo, mut hi) = (p, p);
                                lo[a] = p[a].saturating_sub(h);
                                hi[a] = (p[a] + h).min(d[a] - 1);
                                let c = (f(hi) - f(lo)) / (2.0 * h as f32) * (1.0 / fields.scale);
                                c.clamp(-32767.0, 32767.0).round() as i16
                            });
                            assert_eq!(*got, want, "{kind:?} brick {b:?} entry {lc:?}");
                        }
                    }
                }
            }
        }
        assert!(interior >= 2, "the grid has interior bricks to test the direct path on");
    }

    /// A value block's gradient read four lanes a corner (the fourth the next entry's first component,
    /// up to the padding entry) is the one read three lanes a corner with a zero fourth, at every cell of
    /// the block including the last.
    #[test]
    fn four_lane_corner_reads_give_the_three_lane_gradient() {
        let vol = crate::volume::generate::engine_like_u16([21, 30, 27]);
        let mats = [MaterialClass::new([18.0 * 257.0, 75.0 * 257.0], 0.3), MaterialClass::new([2e4, 6e4], 0.8)];
        let classifier = Classifier::new(&vol, &mats, 0.5, 1);
        let mut nonzero = 0;
        for kind in [Kind::Values, Kind::Opacity] {
            let fields = Fields::new(&vol, &classifier, kind, true, u64::MAX, None);
            for b in [[0, 0, 0], [1, 1, 1], [2, 3, 3]] {
                let block = fields.build(b);
                assert_eq!(block.grad.len(), S3 + 1, "the padding entry");
                for l in 0..BRICK * BRICK * BRICK {
                    let base = l % BRICK + S * ((l / BRICK) % BRICK + S * (l / (BRICK * BRICK)));
                    for f in [[0.0, 0.0, 0.0], [0.3, 0.7, 0.1], [0.9, 0.2, 0.6], [1.0, 1.0, 1.0]] {
                        let got = fields.gradient(&block, base, f);
                        assert_eq!(
                            got,
                            fields.gradient_unpadded(&block, base, f),
                            "{kind:?} {b:?} cell {base} at {f:?}"
                        );
                        nonzero += usize::from(got != [0.0; 3]);
                    }
                }
            }
        }
        assert!(nonzero > 1000, "{nonzero}");
    }

    /// The AVX2 build of a gradient block (where the processor has it) is the portable build, entry for
    /// entry, for every brick (interior and clamped edges) and both field kinds.
    #[test]
    fn the_avx2_block_build_is_the_portable_one() {
        if !crate::render::raycast::lanes_detected() {
            eprintln!("no AVX2 on this processor: nothing to compare");
            return;
        }
        let vol = crate::volume::generate::engine_like_u16([21, 30, 27]);
        let mats = [MaterialClass::new([18.0 * 257.0, 75.0 * 257.0], 0.3), MaterialClass::new([2e4, 6e4], 0.8)];
        let classifier = Classifier::new(&vol, &mats, 0.5, 1);
        for kind in [Kind::Values, Kind::Opacity] {
            let mut fields = Fields::new(&vol, &classifier, kind, true, u64::MAX, None);
            let c = fields.counts;
            for b in (0..c[0] * c[1] * c[2]).map(|i| [i % c[0], (i / c[0]) % c[1], i / (c[0] * c[1])]) {
                fields.avx2 = false;
                let portable = fields.build_gradient(b);
                fields.avx2 = true;
                assert_eq!(fields.build_gradient(b), portable, "{kind:?} brick {b:?}");
            }
        }
    }

    #[test]
    fn rounding_without_the_library_call_is_round() {
        for i in -40_000..40_000 {
            let c = i as f32 * 0.25 + if i % 3 == 0 { 1e-3 } else { 0.0 };
            assert_eq!(super::round_half_away(c), c.round() as i32, "{c}");
        }
        for c in [0.49999997f32, -0.49999997, 0.5, -0.5, 32767.0, -32767.0, 32766.5, -32766.5] {
            assert_eq!(super::round_half_away(c), c.round() as i32, "{c}");
        }
        assert_eq!(super::round_half_away(f32::NAN), 0);
    }
}

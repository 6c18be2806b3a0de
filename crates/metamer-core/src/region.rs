//! One anonymous memory mapping asked for transparent huge pages, handed out as zeroed slices by a bump
//! pointer, for many small buffers that live as long as one another (a raycast's pinned field blocks).
//!
//! Why: the first touch of a fresh 4 KiB page costs a fault and the kernel's clearing of it (about 2 µs a
//! page on the machines measured, see docs/render_performance.md), so 17 MiB of blocks built during a
//! raycast cost ~9 ms of faults. In one region advised `MADV_HUGEPAGE` (transparent huge pages are
//! commonly in `madvise` mode) the same bytes arrive in 2 MiB pages: nine faults instead of ~4400, and
//! one malloc per block less. Where huge pages are off the region still saves the mallocs and behaves
//! as ordinary memory; where the mapping fails the caller falls back to the heap.
//!
//! Only pages touched become resident (with huge pages, at most one 2 MiB page beyond the bytes handed
//! out), so the reservation can be an upper bound. Nothing is freed before the region: each [`Chunk`]
//! holds the region alive, and the mapping is unmapped when the last one drops.
//!
//! All the `unsafe` of the mapping is here, behind [`Region::new`], [`Region::take`] and [`Chunk`]'s
//! `Deref`/`DerefMut`; [`Buf`] wraps a chunk or a `Vec` as one slice type for the callers.

use bytemuck::Zeroable;
use std::marker::PhantomData;
use std::ops::{Deref, DerefMut};
use std::ptr::NonNull;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The transparent huge page size on x86-64 (the mapping's start is aligned to it so that whole huge
/// pages fit).
const HUGE: usize = 2 << 20;

/// A reserved mapping and how much of it has been handed out.
pub(crate) struct Region {
    /// The whole mapping as `mmap` returned it (unmapped on drop).
    map: NonNull<u8>,
    map_len: usize,
    /// Where the handed-out bytes start (`map` rounded up to [`HUGE`]) and how many may be handed out.
    start: usize,
    len: usize,
    /// Bytes handed out so far (from `start`).
    next: AtomicUsize,
}

// SAFETY: the region's memory is only reached through disjoint chunks (the bump pointer hands out each
// byte once), and its own fields are an address, lengths and an atomic.
unsafe impl Send for Region {}
unsafe impl Sync for Region {}

impl Region {
    /// Reserve `bytes` (rounded up to whole huge pages), advised for huge pages; None when the mapping
    /// fails (the caller uses the heap instead). Nothing becomes resident until touched.
    pub(crate) fn new(bytes: usize) -> Option<Arc<Region>> {
        let len = bytes.max(1).checked_next_multiple_of(HUGE)?;
        let map_len = len.checked_add(HUGE)?;
        // SAFETY: an anonymous private mapping at an address of the kernel's choosing aliases nothing; the
        // result is checked before use.
        let map = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                map_len,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_PRIVATE | libc::MAP_ANONYMOUS | libc::MAP_NORESERVE,
                -1,
                0,
            )
        };
        if map == libc::MAP_FAILED {
            return None;
        }
        let map = NonNull::new(map.cast::<u8>())?;
        let start = (map.as_ptr() as usize).next_multiple_of(HUGE) - map.as_ptr() as usize;
        // SAFETY: [start, start + len) lies within the mapping (map_len = len + HUGE > start + len − 1). The
        // advice only changes how pages are backed; refused (huge pages off), the region is ordinary memory.
        unsafe { libc::madvise(map.as_ptr().add(start).cast(), len, libc::MADV_HUGEPAGE) };
        Some(Arc::new(Region { map, map_len, start, len, next: AtomicUsize::new(0) }))
    }

    /// `n` zeroed `T`s of the region (fresh anonymous pages are zero, and each byte is handed out once),
    /// or None when the region has no room left for them. `T: Copy`: a chunk never drops its elements (the
    /// mapping is unmapped whole), so only types without drop glue are handed out.
    pub(crate) fn take<T: Zeroable + Copy>(self: &Arc<Self>, n: usize) -> Option<Chunk<T>> {
        let size = std::mem::size_of::<T>().checked_mul(n)?;
        let align = std::mem::align_of::<T>();
        let mut at = self.next.load(Ordering::Relaxed);
        loop {
            let begin = at.checked_next_multiple_of(align)?;
            let end = begin.checked_add(size)?;
            if end > self.len {
                return None;
            }
            match self.next.compare_exchange_weak(at, end, Ordering::Relaxed, Ordering::Relaxed) {
                Ok(_) => {
                    // `start` is HUGE-aligned, so `begin` keeps T's alignment.
                    // SAFETY: begin + size ≤ len, within the mapping.
                    let ptr = unsafe { self.map.as_ptr().add(self.start + begin) }.cast::<T>();
                    let ptr = NonNull::new(ptr)?;
                    return Some(Chunk { ptr, len: n, _region: Arc::clone(self), _t: PhantomData });
                }
                Err(now) => at = now,
            }
        }
    }

    /// Bytes handed out so far.
    #[cfg(test)]
    pub(crate) fn used(&self) -> usize {
        self.next.load(Ordering::Relaxed)
    }
}

impl Drop for Region {
    fn drop(&mut self) {
        // SAFETY: the mapping made in `new`, unmapped once: every chunk holds the region, so none is left.
        unsafe { libc::munmap(self.map.as_ptr().cast(), self.map_len) };
    }
}

/// Ask for `buf`'s whole 2 MiB-aligned huge pages to be backed by transparent huge pages where they are
/// first touched: for a large buffer just allocated and not yet written (a zeroed allocation that big
/// is fresh mapped memory), its first touches then take a fault per 2 MiB instead of per 4 KiB. Only
/// how pages are backed changes, never the contents, and only pages inside `buf` are advised, so the
/// resident size stays within the buffer's. Refused advice (huge pages off) leaves ordinary pages.
pub(crate) fn advise_huge<T>(buf: &mut [T]) {
    let begin = buf.as_mut_ptr() as usize;
    let end = begin + std::mem::size_of_val(buf);
    let first = begin.next_multiple_of(HUGE);
    let last = end / HUGE * HUGE;
    if last > first {
        // SAFETY: [first, last) lies within `buf`, memory this caller holds mutably; MADV_HUGEPAGE
        // changes how its pages are backed, not what they hold.
        unsafe { libc::madvise(first as *mut libc::c_void, last - first, libc::MADV_HUGEPAGE) };
    }
}

/// `len` `T`s of a [`Region`], handed out to one owner only.
pub(crate) struct Chunk<T> {
    ptr: NonNull<T>,
    len: usize,
    _region: Arc<Region>,
    _t: PhantomData<T>,
}

// SAFETY: a chunk owns its bytes exclusively (as a Box<[T]> would) and keeps the mapping alive.
unsafe impl<T: Send> Send for Chunk<T> {}
unsafe impl<T: Sync> Sync for Chunk<T> {}

impl<T> Deref for Chunk<T> {
    type Target = [T];
    #[inline(always)]
    fn deref(&self) -> &[T] {
        // SAFETY: `len` Ts, aligned, zero-initialised (valid: T is Zeroable) or since written through
        // `deref_mut`, within the live mapping and reached by no other chunk.
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr(), self.len) }
    }
}

impl<T> DerefMut for Chunk<T> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [T] {
        // SAFETY: as in `deref`, and `&mut self` makes this the only reference.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.as_ptr(), self.len) }
    }
}

/// A buffer of `T`s from a [`Region`] or the heap, read as one slice.
pub(crate) enum Buf<T> {
    Heap(Vec<T>),
    Region(Chunk<T>),
}

impl<T: Zeroable + Copy> Buf<T> {
    /// `n` zeroed `T`s from `region` while it has room, else from the heap.
    pub(crate) fn zeroed(region: Option<&Arc<Region>>, n: usize) -> Buf<T> {
        match region.and_then(|r| r.take(n)) {
            Some(c) => Buf::Region(c),
            None => Buf::Heap(vec![T::zeroed(); n]),
        }
    }
}

impl<T> From<Vec<T>> for Buf<T> {
    fn from(v: Vec<T>) -> Self {
        Buf::Heap(v)
    }
}

impl<T> Deref for Buf<T> {
    type Target = [T];
    #[inline(always)]
    fn deref(&self) -> &[T] {
        match self {
            Buf::Heap(v) => v,
            Buf::Region(c) => c,
        }
    }
}

impl<T> DerefMut for Buf<T> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [T] {
        match self {
            Buf::Heap(v) => v,
            Buf::Region(c) => c,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_are_zeroed_disjoint_and_outlive_their_region_handle() {
        let region = Region::new(10_000).expect("an anonymous mapping");
        let mut a: Chunk<[i16; 3]> = region.take(100).expect("room");
        let mut b: Chunk<u8> = region.take(7).expect("room");
        let mut c: Chunk<u64> = region.take(3).expect("room");
        assert!(a.iter().all(|v| *v == [0; 3]) && b.iter().all(|&v| v == 0) && c.iter().all(|&v| v == 0));
        assert_eq!((a.len(), b.len(), c.len()), (100, 7, 3));
        // Aligned for their type after an odd-sized chunk.
        assert_eq!(c.as_ptr() as usize % std::mem::align_of::<u64>(), 0);
        a.iter_mut().enumerate().for_each(|(i, v)| *v = [i as i16, -(i as i16), 7]);
        b.fill(0xAB);
        c.fill(u64::MAX);
        // Writing one chunk leaves the others as written: no two share a byte.
        assert!(a.iter().enumerate().all(|(i, v)| *v == [i as i16, -(i as i16), 7]));
        assert!(b.iter().all(|&v| v == 0xAB) && c.iter().all(|&v| v == u64::MAX));
        assert_eq!(region.used(), 600 + 7 + 1 + 24);
        // The chunks keep the mapping alive after the last region handle goes.
        drop(region);
        assert_eq!(a[99], [99, -99, 7]);
    }

    #[test]
    fn a_full_region_says_so_and_buf_falls_back_to_the_heap() {
        // One huge page of room.
        let region = Region::new(1).expect("an anonymous mapping");
        let whole: Chunk<u8> = region.take(HUGE).expect("the whole region");
        assert!(region.take::<u8>(1).is_none());
        assert!(region.take::<u64>(usize::MAX).is_none(), "an overflowing size is refused");
        let b: Buf<u16> = Buf::zeroed(Some(&region), 5);
        assert!(matches!(b, Buf::Heap(_)) && b.len() == 5 && b.iter().all(|&v| v == 0));
        drop(whole);
        let fresh = Region::new(64).expect("an anonymous mapping");
        let r: Buf<u16> = Buf::zeroed(Some(&fresh), 5);
        assert!(matches!(r, Buf::Region(_)) && r.len() == 5);
    }

    /// Whether the huge pages of [first, first + len) are advised (`hg` among the VmFlags of the mapping
    /// holding them in /proc/self/smaps); None where smaps cannot be read.
    fn advised(first: usize) -> Option<bool> {
        let smaps = std::fs::read_to_string("/proc/self/smaps").ok()?;
        let mut inside = false;
        for line in smaps.lines() {
            if let Some((range, _)) = line.split_once(' ')
                && let Some((a, b)) = range.split_once('-')
                && let (Ok(a), Ok(b)) = (usize::from_str_radix(a, 16), usize::from_str_radix(b, 16))
            {
                inside = a <= first && first < b;
            } else if inside && let Some(flags) = line.strip_prefix("VmFlags:") {
                return Some(flags.split_whitespace().any(|f| f == "hg"));
            }
        }
        None
    }

    #[test]
    fn a_large_buffer_is_advised_and_keeps_its_contents() {
        let mut v: Vec<u32> = (0..3 * HUGE as u32 / 4).collect();
        let first = (v.as_ptr() as usize).next_multiple_of(HUGE);
        advise_huge(&mut v);
        assert!(v.iter().enumerate().all(|(i, &x)| x as usize == i));
        if let Some(hg) = advised(first) {
            assert!(hg, "the buffer's huge pages advised");
        }
        // A buffer holding no whole huge page is left alone (nothing outside it may be advised).
        let mut small = vec![1u8; 4096];
        advise_huge(&mut small);
        assert!(small.iter().all(|&x| x == 1));
    }

    #[test]
    fn chunks_taken_from_threads_at_once_never_overlap() {
        let region = Region::new(1 << 20).expect("an anonymous mapping");
        let chunks: Vec<Chunk<u32>> = std::thread::scope(|s| {
            let hs: Vec<_> = (0..4)
                .map(|t| {
                    let region = &region;
                    s.spawn(move || {
                        (0..200)
                            .map(|_| {
                                let mut c = region.take::<u32>(37).expect("room");
                                c.fill(t);
                                c
                            })
                            .collect::<Vec<_>>()
                    })
                })
                .collect();
            hs.into_iter().flat_map(|h| h.join().expect("a taker")).collect()
        });
        let mut spans: Vec<(usize, usize)> = chunks.iter().map(|c| (c.as_ptr() as usize, c.len() * 4)).collect();
        spans.sort_unstable();
        assert!(spans.windows(2).all(|w| w[0].0 + w[0].1 <= w[1].0));
        assert_eq!(region.used(), 800 * 37 * 4);
    }
}

//! The pool threads' heaps in transparent huge pages.
//!
//! Why: a batch `metamer solve` of 1200 designs touched about 11 MB of fresh memory, 2 700 first touches of
//! a 4 KiB page, each a fault and a cleared page (about 2 µs each here); two thirds of them were in the
//! heaps of rayon's workers (the reader's pieces, the solve's workspaces, the report's rows). glibc gives
//! each thread that allocates an arena of its own, whose heap is one mapping aligned to its maximum size
//! and grown inside it; where transparent huge pages are in `madvise` mode (the common default) that heap
//! never gets them. glibc's own tunable `glibc.malloc.hugetlb=1` advises its heaps when it maps them, but
//! it is read from the environment when the process starts, so a program cannot set it for itself.
//!
//! What: each pool thread, first thing (rayon's start handler), allocates once so that its arena exists,
//! advises its heap's whole mapping `MADV_HUGEPAGE`, and asks the kernel to collapse the heap's first 2 MiB,
//! which the arena's own header has already touched in 4 KiB pages, into one huge page (`MADV_COLLAPSE`,
//! Linux 6.1). From then on the heap's pages arrive 2 MiB at a time. Measured in
//! docs/solve_performance.md ("The pool threads' heaps in huge pages").
//!
//! How a thread's heap is found: glibc maps a thread arena's heap at an address aligned to `HEAP_MAX_SIZE`
//! (64 MiB on 64-bit targets: twice `DEFAULT_MMAP_THRESHOLD_MAX`) and finds a chunk's heap by rounding its
//! address down to that size (`heap_for_ptr` in glibc's `malloc/arena.c`). The main arena is the program
//! break's heap instead, below `sbrk(0)`; a block at or above the break is in a mapped heap. A thread that
//! shares the main arena is left alone. Everything here only advises the kernel: a wrong guess about the
//! heap's place changes which pages may be huge, never what memory holds, and a kernel or allocator without
//! these calls ignores them (their errors are not needed).

/// Build rayon's global pool (its size as before: `RAYON_NUM_THREADS`, set by `size_pool`) with each
/// worker's heap advised for huge pages. Called once the command line is parsed, so `--help` and
/// `--version` start no threads; if a pool exists already (a test calling `run` twice), it is kept.
pub(crate) fn build_pool() {
    let _ = rayon::ThreadPoolBuilder::new()
        .start_handler(|_| {
            advise_this_threads_heap();
        })
        .build_global();
}

/// Advise the calling thread's glibc heap for transparent huge pages (see the module's documentation).
/// Returns where the heap's mapping starts when it advised one.
#[cfg(all(target_os = "linux", target_env = "gnu", target_pointer_width = "64"))]
pub(crate) fn advise_this_threads_heap() -> Option<usize> {
    /// glibc's `HEAP_MAX_SIZE` on 64-bit targets.
    const HEAP_MAX: usize = 64 << 20;
    /// The transparent huge page size on x86-64 and the common arm64 configuration.
    const HUGE: usize = 2 << 20;
    // SAFETY: `sbrk(0)` moves nothing; it returns the current program break.
    let brk = unsafe { libc::sbrk(0) } as usize;
    // A block from this thread's arena, created by this thread's first allocation. The very first block a
    // new thread asks for can come from the main arena while the thread's cache is being set up (seen
    // with glibc 2.36), so a second one is asked for if it did. Blocks are only looked at as addresses.
    let (first, second) = (Box::new(0u64), Box::new(0u64));
    let addr = |b: &u64| std::hint::black_box(b as *const u64 as usize);
    let at = [addr(&first), addr(&second)].into_iter().find(|&at| at >= brk)?;
    drop((first, second));
    let base = at & !(HEAP_MAX - 1);
    // SAFETY: `madvise` with these two advices changes only how the range's pages are backed (whether they
    // may be, or now become, transparent huge pages), never what they hold; the range is page-aligned.
    // Parts of it that are not mapped make the call fail without effect there.
    unsafe {
        libc::madvise(base as *mut libc::c_void, HEAP_MAX, libc::MADV_HUGEPAGE);
        libc::madvise(base as *mut libc::c_void, HUGE, libc::MADV_COLLAPSE);
    }
    Some(base)
}

/// Elsewhere there is no glibc heap to advise.
#[cfg(not(all(target_os = "linux", target_env = "gnu", target_pointer_width = "64")))]
pub(crate) fn advise_this_threads_heap() -> Option<usize> {
    None
}

#[cfg(all(test, target_os = "linux", target_env = "gnu", target_pointer_width = "64"))]
mod tests {
    use super::advise_this_threads_heap;
    use std::sync::{Arc, Barrier};

    const HEAP_MAX: usize = 64 << 20;

    /// The kB of anonymous huge pages in the mappings that lie in `[from, to)`, from `/proc/self/smaps`.
    fn huge_kb_in(from: usize, to: usize) -> u64 {
        let smaps = std::fs::read_to_string("/proc/self/smaps").expect("/proc/self/smaps is readable");
        let mut inside = false;
        let mut kb = 0;
        for line in smaps.lines() {
            if let Some((range, _)) = line.split_once(' ')
                && let Some((a, b)) = range.split_once('-')
                && let (Ok(a), Ok(b)) = (usize::from_str_radix(a, 16), usize::from_str_radix(b, 16))
            {
                inside = a >= from && b <= to;
                continue;
            }
            if inside && let Some(v) = line.strip_prefix("AnonHugePages:") {
                kb += v.trim().trim_end_matches("kB").trim().parse::<u64>().unwrap_or(0);
            }
        }
        kb
    }

    /// A thread fills 24 MiB of its heap in 64 KiB blocks (below glibc's mapping threshold, so from its
    /// arena), with or without the advice first, and reports its heap's mapping and the huge pages in it.
    /// Both threads of a test stay alive until both have looked, so that each has an arena of its own (a
    /// thread that exits hands its arena to the next new one).
    fn fill_a_threads_heap(advise: bool, both: Arc<Barrier>) -> std::thread::JoinHandle<(usize, Option<usize>, u64)> {
        std::thread::spawn(move || {
            let advised = if advise { advise_this_threads_heap() } else { None };
            let blocks: Vec<Vec<u8>> = (0..384).map(|i| vec![i as u8 | 1; 64 << 10]).collect();
            assert!(blocks.iter().all(|b| b[1000] != 0));
            let base = blocks[192].as_ptr() as usize & !(HEAP_MAX - 1);
            let huge = huge_kb_in(base, base + HEAP_MAX);
            both.wait();
            (base, advised, huge)
        })
    }

    /// The check itself, in a process of its own ([`an_advised_threads_heap_is_filled_in_huge_pages`] runs it):
    /// glibc makes at most eight arenas a core, so in the test harness's crowded process a new thread can be
    /// handed the main arena, which the advice rightly leaves alone.
    #[test]
    #[ignore = "run in a process of its own by an_advised_threads_heap_is_filled_in_huge_pages"]
    fn advised_heap_in_its_own_process() {
        let mode = std::fs::read_to_string("/sys/kernel/mm/transparent_hugepage/enabled").unwrap_or_default();
        if !mode.contains("[madvise]") && !mode.contains("[always]") {
            eprintln!("transparent huge pages are off here ({}): nothing to check", mode.trim());
            return;
        }
        // As in `main`: heaps grow 8 MiB at a time, so that whole 2 MiB ranges of them are mapped at once.
        crate::cli::tune_allocator();
        let both = Arc::new(Barrier::new(2));
        let advised = fill_a_threads_heap(true, both.clone());
        let plain = fill_a_threads_heap(false, both);
        let (base, advised_base, huge) = advised.join().expect("the advised thread panicked");
        let (plain_base, _, plain_huge) = plain.join().expect("the plain thread panicked");
        assert_eq!(advised_base, Some(base), "the advice found the heap its blocks came from");
        assert_ne!(base, plain_base, "the two threads had one heap");
        assert!(huge >= 8 << 10, "the advised heap holds {huge} kB of huge pages for 24 MiB of blocks");
        if mode.contains("[madvise]") {
            assert_eq!(plain_huge, 0, "without the advice a heap holds no huge pages in madvise mode");
        }
    }

    #[test]
    fn an_advised_threads_heap_is_filled_in_huge_pages() {
        let name = "cli::heap::tests::advised_heap_in_its_own_process";
        let exe = std::env::current_exe().expect("the test binary's path");
        let out = std::process::Command::new(exe)
            .args([name, "--exact", "--ignored", "--test-threads=1", "--nocapture"])
            .output()
            .expect("the test binary runs again");
        let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
        assert!(out.status.success(), "{name} failed in its own process:\n{text}");
        assert!(text.contains("1 passed"), "{name} did not run in its own process:\n{text}");
    }
}

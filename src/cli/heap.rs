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
//! advises its heap's whole mapping `MADV_HUGEPAGE`, and takes the rest of the heap's first 2 MiB, which the
//! arena's own header has already touched in 4 KiB pages, with blocks it holds for good (2 MiB of address
//! space and about 17 touched pages a worker; collapsing that range into a huge page instead,
//! `MADV_COLLAPSE`, cost 0.3–1.1 ms a worker and needs Linux 6.1). From then on the pages of the heap's first
//! mapping (the allocator's top pad, [`crate::cli::TOP_PAD`]: 8 MiB) arrive 2 MiB at a time. Past it glibc
//! grows a thread's heap by what each request needs, so a 2 MiB range there is never whole when first
//! written and its pages are 4 KiB ones (the kernel's `khugepaged` may merge them later); the solve's workers
//! stay inside their first 8 MiB. Measured in docs/solve_performance.md ("The pool threads' heaps in huge
//! pages").
//!
//! How a thread's heap is found: glibc maps a thread arena's heap at an address aligned to `HEAP_MAX_SIZE`
//! (64 MiB on 64-bit targets: twice `DEFAULT_MMAP_THRESHOLD_MAX`) and finds a chunk's heap by rounding its
//! address down to that size (`heap_for_ptr` in glibc's `malloc/arena.c`). The main arena is the program
//! break's heap instead, below `sbrk(0)`; a block at or above the break is in a mapped heap. A thread that
//! shares the main arena is left alone. Everything here only advises the kernel: a wrong guess about the
//! heap's place changes which pages may be huge, never what memory holds, and a kernel or allocator without
//! these calls ignores them (their errors are not needed).

/// Build rayon's global pool with `threads` workers (`None`: rayon's own choice, which reads
/// `RAYON_NUM_THREADS`), each worker's heap advised for huge pages. Called once the command line is parsed, so
/// `--help` and `--version` start no threads; if a pool exists already (a test calling `run` twice), it is
/// kept.
pub(crate) fn build_pool(threads: Option<usize>) {
    let builder = rayon::ThreadPoolBuilder::new().start_handler(|_| {
        advise_this_threads_heap();
    });
    let _ = match threads {
        Some(n) => builder.num_threads(n),
        None => builder,
    }
    .build_global();
}

/// glibc's `HEAP_MAX_SIZE` on 64-bit targets: a thread arena's heap is mapped at an address aligned to it.
#[cfg(all(target_os = "linux", target_env = "gnu", target_pointer_width = "64"))]
const HEAP_MAX: usize = 64 << 20;

/// Advise the calling thread's glibc heap for transparent huge pages (see the module's documentation).
/// Returns where the heap's mapping starts when it advised one.
#[cfg(all(target_os = "linux", target_env = "gnu", target_pointer_width = "64"))]
pub(crate) fn advise_this_threads_heap() -> Option<usize> {
    /// The transparent huge page size on x86-64 and the common arm64 configuration.
    const HUGE: usize = 2 << 20;
    /// A block that fills the heap's first huge page: under glibc's initial mapping threshold (128 KiB),
    /// so it comes from the heap; about 17 of them reach the 2 MiB boundary.
    const FILLER: usize = 120 << 10;
    /// At most this many (3.75 MiB) are asked for, whatever the heap does.
    const MAX_FILLERS: usize = 32;
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
    // SAFETY: `madvise(MADV_HUGEPAGE)` changes only whether the range's pages may be transparent huge pages
    // when first touched, never what they hold; the range is page-aligned. Parts of it that are not mapped
    // make the call fail without effect there.
    unsafe { libc::madvise(base as *mut libc::c_void, HEAP_MAX, libc::MADV_HUGEPAGE) };
    // The heap's first 2 MiB were touched in 4 KiB pages before the advice (the arena's own header), so a
    // huge page can no longer be put there: the rest of that range is taken by blocks held for good, and
    // the thread's memory comes from the huge pages past it. Each block, asked for below glibc's mapping
    // threshold, is cut from the top of the heap; only its header's page is touched.
    for _ in 0..MAX_FILLERS {
        // SAFETY: a plain allocation; it is freed below if it did not come from this heap, and otherwise
        // held for the thread's (the pool's) lifetime.
        let filler = unsafe { libc::malloc(FILLER) } as usize;
        if filler == 0 {
            break;
        }
        if !(base..base + HEAP_MAX).contains(&filler) {
            // SAFETY: `filler` came from `malloc` above and is not used again.
            unsafe { libc::free(filler as *mut libc::c_void) };
            break;
        }
        if filler + FILLER >= base + HUGE {
            break;
        }
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
    use super::{HEAP_MAX, advise_this_threads_heap};
    use std::sync::{Arc, Barrier};

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

    /// A thread fills its heap in 64 KiB blocks (below glibc's mapping threshold, so from its arena), with or
    /// without the advice first, and reports its heap's mapping, what the advice returned, and the huge pages
    /// in the heap's mapping after its first 1 MiB of blocks and after 24 MiB. Both threads of a test stay
    /// alive until both have looked, so that each has an arena of its own (a thread that exits hands its
    /// arena to the next new one).
    fn fill_a_threads_heap(
        advise: bool,
        both: Arc<Barrier>,
    ) -> std::thread::JoinHandle<(usize, Option<usize>, u64, u64)> {
        std::thread::spawn(move || {
            let advised = if advise { advise_this_threads_heap() } else { None };
            let mut blocks: Vec<Vec<u8>> = Vec::with_capacity(384);
            let mut first_mib = 0;
            for i in 0..384 {
                blocks.push(vec![i as u8 | 1; 64 << 10]);
                if i == 15 {
                    let at = blocks[0].as_ptr() as usize & !(HEAP_MAX - 1);
                    first_mib = huge_kb_in(at, at + HEAP_MAX);
                }
            }
            assert!(blocks.iter().all(|b| b[1000] != 0));
            let base = blocks[192].as_ptr() as usize & !(HEAP_MAX - 1);
            let huge = huge_kb_in(base, base + HEAP_MAX);
            both.wait();
            (base, advised, first_mib, huge)
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
        // As in `main`: a heap is made with 8 MiB mapped, so that whole 2 MiB ranges of it are mapped at once.
        crate::cli::tune_allocator();
        let both = Arc::new(Barrier::new(2));
        let advised = fill_a_threads_heap(true, both.clone());
        let plain = fill_a_threads_heap(false, both);
        let (base, advised_base, first_mib, huge) = advised.join().expect("the advised thread panicked");
        let (plain_base, _, _, plain_huge) = plain.join().expect("the plain thread panicked");
        assert_eq!(advised_base, Some(base), "the advice found the heap its blocks came from");
        assert_ne!(base, plain_base, "the two threads had one heap");
        // The heap's first 2 MiB, touched before the advice, are taken: the first blocks are in a huge page.
        assert!(first_mib >= 2 << 10, "the advised heap's first 1 MiB of blocks are in {first_mib} kB of huge pages");
        // The rest of the heap's first mapping (the top pad) is in huge pages. Past it the heap grows by one
        // block at a time, so those pages are 4 KiB ones unless `khugepaged` has merged some meanwhile.
        let whole = (crate::cli::TOP_PAD - (2 << 20)) as u64 >> 10;
        assert!(huge >= whole, "the advised heap holds {huge} kB of huge pages for 24 MiB of blocks, not {whole}");
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

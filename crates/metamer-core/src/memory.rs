//! How much memory this process may use, and refusing work that needs more — early, with a message
//! naming what needs it, never an out-of-memory kill.
//!
//! [`available`] is the least of: the kernel's `MemAvailable` (`/proc/meminfo`), the control group's limit
//! minus its usage (cgroup v2 `memory.max` − `memory.current`, or v1 `memory.limit_in_bytes` −
//! `memory.usage_in_bytes`; reclaimable inactive file cache counted as free), and the
//! `METAMER_MEMORY_LIMIT` environment variable (MiB: a cap for shared machines and batch jobs). Where none
//! is known (not Linux), nothing is refused. [`ensure`] is the one check every large allocation makes.

/// Bytes in a MiB.
pub const MIB: u64 = 1 << 20;

/// The environment variable capping the memory metamer plans for (MiB).
pub const LIMIT_ENV: &str = "METAMER_MEMORY_LIMIT";

/// Memory available to this process and what limits it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Available {
    pub(crate) bytes: u64,
    /// `"MemAvailable"`, `"cgroup limit"` or `"METAMER_MEMORY_LIMIT"`.
    pub source: &'static str,
}

/// Work that needs more memory than is available.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "{what} needs about {} MiB; this machine has {} MiB available ({limit})",
    needed.div_ceil(MIB),
    available / MIB
)]
pub struct MemoryError {
    pub(crate) what: String,
    pub(crate) needed: u64,
    pub(crate) available: u64,
    /// What limits it (as [`Available::source`]).
    pub limit: &'static str,
}

/// `bytes` in MiB for messages: one decimal below 10 MiB, whole MiB above.
pub fn show_mib(bytes: u64) -> String {
    let m = bytes as f64 / MIB as f64;
    if m < 10.0 { format!("{m:.1}") } else { format!("{m:.0}") }
}

/// The memory available now (None when it cannot be known).
pub fn available() -> Option<Available> {
    let mut best: Option<Available> = None;
    let mut offer = |bytes: Option<u64>, source: &'static str| {
        if let Some(bytes) = bytes
            && best.is_none_or(|b| bytes < b.bytes)
        {
            best = Some(Available { bytes, source });
        }
    };
    offer(std::fs::read_to_string("/proc/meminfo").ok().as_deref().and_then(mem_available), "MemAvailable");
    offer(cgroup_available(), "cgroup limit");
    offer(env_limit(std::env::var(LIMIT_ENV).ok().as_deref()), LIMIT_ENV);
    best
}

/// Refuse `needed` bytes of work when less is available; `what` (called only on refusal) says what needs
/// them, e.g. `"volume v.nrrd is 512×512×384 u16 = 192 MiB; rendering it"`.
pub fn ensure(what: impl FnOnce() -> String, needed: u64) -> Result<(), MemoryError> {
    match available() {
        Some(a) if needed > a.bytes => Err(MemoryError { what: what(), needed, available: a.bytes, limit: a.source }),
        _ => Ok(()),
    }
}

/// What rendering a volume of `voxel_bytes` may take at the usual frame sizes (≤ 1024²): the voxels, half as
/// much again for the derived fields (gradients, skipping structure) and 160 MiB for images, model and code.
/// This is the budget the renderer is held to (issue 25): the derived fields are capped at half the voxels
/// (at least 64 MiB, `render::raycast::default_field_cache`), the others evicted. Measured for
/// 192 MiB of u16 voxels (512×512×384) at 512²: peak 313–316 MiB against this 448 MiB, with a transfer
/// function whose rays reach every brick (886 MiB before the cap).
pub fn render_estimate(voxel_bytes: u64) -> u64 {
    voxel_bytes.saturating_add(voxel_bytes / 2).saturating_add(160 * MIB)
}

/// `MemAvailable` of `/proc/meminfo` text, in bytes.
fn mem_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// `METAMER_MEMORY_LIMIT` (MiB, a whole number) in bytes; unset, empty or unreadable → None.
fn env_limit(value: Option<&str>) -> Option<u64> {
    value?.trim().parse::<u64>().ok()?.checked_mul(MIB)
}

/// This process's control group: limit − usage + inactive file cache (v2, then v1).
fn cgroup_available() -> Option<u64> {
    let groups = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let read = |p: String| std::fs::read_to_string(p).ok();
    for line in groups.lines() {
        let mut parts = line.splitn(3, ':');
        let (_, controllers, path) = (parts.next()?, parts.next()?, parts.next()?);
        let path = path.trim_end_matches('/');
        let (base, limit, usage, inactive) = if controllers.is_empty() {
            ("/sys/fs/cgroup", "memory.max", "memory.current", "inactive_file")
        } else if controllers.split(',').any(|c| c == "memory") {
            ("/sys/fs/cgroup/memory", "memory.limit_in_bytes", "memory.usage_in_bytes", "total_inactive_file")
        } else {
            continue;
        };
        // The group's own folder, then the mount's root (inside a container the group is often the root).
        for d in [format!("{base}{path}"), base.to_string()] {
            let avail = group_available(
                read(format!("{d}/{limit}")),
                read(format!("{d}/{usage}")),
                read(format!("{d}/memory.stat")),
                inactive,
            );
            if avail.is_some() {
                return avail;
            }
        }
    }
    None
}

/// Limit − usage + inactive file cache, from a group's files (None without a numeric limit, or with an
/// absurd one: "max", or v1's 2⁶³-ish "unlimited").
fn group_available(
    limit: Option<String>,
    usage: Option<String>,
    stat: Option<String>,
    inactive_key: &str,
) -> Option<u64> {
    let limit: u64 = limit?.trim().parse().ok()?;
    if limit >= 1 << 60 {
        return None;
    }
    let usage: u64 = usage.and_then(|u| u.trim().parse().ok()).unwrap_or(0);
    let inactive: u64 = stat
        .and_then(|s| {
            s.lines().find_map(|l| {
                let (k, v) = l.split_once(' ')?;
                (k == inactive_key).then(|| v.trim().parse().ok()).flatten()
            })
        })
        .unwrap_or(0);
    Some(limit.saturating_sub(usage.saturating_sub(inactive)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meminfo_and_limits_parse() {
        let text = "MemTotal:       24683584 kB\nMemFree:  100 kB\nMemAvailable:   22558024 kB\n";
        assert_eq!(mem_available(text), Some(22558024 * 1024));
        assert_eq!(mem_available("MemTotal: 5 kB\n"), None);
        assert_eq!(env_limit(Some("512")), Some(512 * MIB));
        assert_eq!(env_limit(Some(" x ")), None);
        assert_eq!(env_limit(None), None);
        let s = |t: &str| Some(t.to_string());
        assert_eq!(group_available(s("max\n"), s("100"), None, "inactive_file"), None);
        assert_eq!(group_available(s("9223372036854771712\n"), s("100"), None, "total_inactive_file"), None);
        let stat = s("anon 5\ninactive_file 300\nactive_file 9\n");
        assert_eq!(group_available(s("1000\n"), s("800\n"), stat, "inactive_file"), Some(500));
        assert_eq!(group_available(s("1000"), s("5000"), None, "inactive_file"), Some(0));
    }

    #[test]
    fn refusal_names_what_needs_how_much() {
        let e = MemoryError {
            what: "volume v.nrrd is 2×2×2 u8 = 0 MiB; rendering it".into(),
            needed: 300 * MIB + 1,
            available: 100 * MIB,
            limit: "MemAvailable",
        };
        assert_eq!(
            e.to_string(),
            "volume v.nrrd is 2×2×2 u8 = 0 MiB; rendering it needs about 301 MiB; this machine has 100 MiB available (MemAvailable)"
        );
        // Nothing this small is refused on a machine that runs the tests.
        assert!(ensure(|| unreachable!(), 1).is_ok());
        assert_eq!(render_estimate(100 * MIB), 310 * MIB);
        assert_eq!((show_mib(MIB / 2), show_mib(192 * MIB + 1)), ("0.5".to_string(), "192".to_string()));
    }
}

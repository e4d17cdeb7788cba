//! Memory: what this process may still use, and a budget that loading
//! counts against it before each large allocation, so that a scene too
//! large for the machine is an error with a message, not an abort.

use std::cell::Cell;

use crate::{Error, Result};

/// Memory this process may still use, in bytes, as far as the system tells:
/// the least of the memory available (`MemAvailable`), what is left of a cgroup
/// limit and what is left of an address-space limit (`ulimit -v`). `None`
/// where none is known (then nothing is refused).
pub fn available_memory() -> Option<u64> {
    let read = |path: &str| std::fs::read_to_string(path).ok();
    let kib_field = |text: &str, key: &str| -> Option<u64> {
        let line = text.lines().find(|l| l.starts_with(key))?;
        let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
        Some(kib.saturating_mul(1024))
    };
    let mut limits = Vec::new();
    if let Some(meminfo) = read("/proc/meminfo") {
        limits.extend(kib_field(&meminfo, "MemAvailable:"));
    }
    let cgroup_max = read("/sys/fs/cgroup/memory.max").and_then(|s| s.trim().parse::<u64>().ok());
    let cgroup_now =
        read("/sys/fs/cgroup/memory.current").and_then(|s| s.trim().parse::<u64>().ok());
    if let (Some(max), Some(now)) = (cgroup_max, cgroup_now) {
        limits.push(max.saturating_sub(now));
    }
    let address_limit = read("/proc/self/limits").and_then(|text| {
        let line = text.lines().find(|l| l.starts_with("Max address space"))?;
        line.split_whitespace().nth(3)?.parse::<u64>().ok()
    });
    let address_used = read("/proc/self/status").and_then(|s| kib_field(&s, "VmSize:"));
    if let (Some(limit), Some(used)) = (address_limit, address_used) {
        limits.push(limit.saturating_sub(used));
    }
    limits.into_iter().min()
}

/// `1.5 GB`, `340 MB`, `12 kB`: decimal units, for messages.
pub fn human_bytes(bytes: u64) -> String {
    let b = bytes as f64;
    match bytes {
        0..=999 => format!("{bytes} bytes"),
        1_000..=999_999 => format!("{:.0} kB", b / 1e3),
        1_000_000..=999_999_999 => format!("{:.0} MB", b / 1e6),
        _ => format!("{:.1} GB", b / 1e9),
    }
}

/// The memory one load may take: what it has taken so far against a limit
/// (the machine's available memory when the load began, or a caller's).
/// Loaders count what they keep ([`Budget::take`]) and check what they
/// only hold for a moment ([`Budget::check`]) before allocating it.
#[derive(Debug)]
pub struct Budget {
    limit: Option<u64>,
    taken: Cell<u64>,
}

impl Budget {
    /// A budget of `limit` bytes (`None`: unlimited).
    pub fn new(limit: Option<u64>) -> Budget {
        Budget {
            limit,
            taken: Cell::new(0),
        }
    }

    /// A budget of what the machine has available now.
    pub fn of_this_machine() -> Budget {
        Budget::new(available_memory())
    }

    /// Bytes taken so far.
    pub fn taken(&self) -> u64 {
        self.taken.get()
    }

    /// Counts `bytes` that will be kept; refuses them, naming `what`, when
    /// they and what was taken before exceed the limit.
    pub fn take(&self, bytes: u64, what: &dyn Fn() -> String) -> Result<()> {
        self.check(bytes, what)?;
        self.taken.set(self.taken.get().saturating_add(bytes));
        Ok(())
    }

    /// Refuses `bytes` held for a moment beside what was taken, naming
    /// `what`, when together they exceed the limit.
    pub fn check(&self, bytes: u64, what: &dyn Fn() -> String) -> Result<()> {
        let Some(limit) = self.limit else {
            return Ok(());
        };
        let total = self.taken.get().saturating_add(bytes);
        if total <= limit {
            return Ok(());
        }
        let before = match self.taken.get() {
            0 => String::new(),
            t => format!(" beside the {} taken before", human_bytes(t)),
        };
        Err(Error::Invalid(format!(
            "{}: needs about {} of memory{before}, but only {} is available",
            what(),
            human_bytes(bytes),
            human_bytes(limit)
        )))
    }
}

/// Reserves room for `more` elements in `v`, as an error naming `what`
/// instead of an abort when the allocator refuses.
pub fn try_reserve<T>(v: &mut Vec<T>, more: usize, what: &dyn Fn() -> String) -> Result<()> {
    v.try_reserve(more).map_err(|_| {
        let bytes = (more as u64).saturating_mul(std::mem::size_of::<T>() as u64);
        Error::Invalid(format!(
            "{}: cannot allocate {} of memory",
            what(),
            human_bytes(bytes)
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_budget_counts_what_is_kept_and_refuses_past_its_limit() {
        let b = Budget::new(Some(1000));
        b.take(600, &|| "a".into()).unwrap();
        // Held for a moment: checked, not counted.
        b.check(400, &|| "b".into()).unwrap();
        assert_eq!(b.taken(), 600);
        let e = b.take(500, &|| "t.gltf: images[3]".into()).unwrap_err();
        let msg = e.to_string();
        assert_eq!(
            msg,
            "t.gltf: images[3]: needs about 500 bytes of memory beside the 600 bytes taken \
             before, but only 1 kB is available"
        );
        assert_eq!(b.taken(), 600, "a refusal takes nothing");
        assert!(Budget::new(None).take(u64::MAX, &|| "x".into()).is_ok());
    }

    #[test]
    fn a_refused_reservation_is_an_error() {
        let mut v: Vec<u64> = Vec::new();
        let e = try_reserve(&mut v, usize::MAX / 4, &|| "f.obj".into()).unwrap_err();
        assert!(e.to_string().starts_with("f.obj: cannot allocate"), "{e}");
        try_reserve(&mut v, 10, &|| "f.obj".into()).unwrap();
        assert!(v.capacity() >= 10);
    }

    #[test]
    fn this_machine_reports_some_memory() {
        // On Linux /proc/meminfo is always there.
        if cfg!(target_os = "linux") {
            assert!(available_memory().is_some_and(|b| b > 0));
        }
    }
}

//! The system allocator, with large blocks backed by transparent huge pages.
//!
//! A render's images are fresh memory (glibc maps every block above its
//! mmap threshold anew, see `fix_mmap_threshold`), and the kernel fills such
//! memory a 4 KiB page at a time, one fault each: a 1024² image of colours is
//! 3,072 faults, and with huge pages a one-thread render of a matte scene at
//! that size takes 10 % less CPU time (docs/benchmarks.md, "Issue 17,
//! fourteenth pass"). Where the kernel backs
//! a block's 2 MiB-aligned stretches with huge pages instead (Linux's
//! transparent huge pages, asked for by `madvise`), one fault fills 2 MiB.
//! This is what glibc's own `glibc.malloc.hugetlb=1` tunable does; a tunable
//! can only be set in the environment before the program starts, so the
//! advice is given here.

use std::alloc::{GlobalAlloc, Layout, System};

/// A transparent huge page. Blocks of at least this size start on a huge
/// page boundary (address space only: the memory is taken as it is touched),
/// so that all their whole huge pages can be backed so: a 512² image of
/// colours (3 MiB) gets one, 2 MiB of its 3.
const HUGE_PAGE: usize = 2 << 20;

/// `System`, advising the kernel to back large blocks with huge pages.
pub struct HugePageAlloc;

/// The layout a block of `layout` is taken from `System` with: aligned to a
/// huge page if it is one at least (the same for a block's allocation and
/// its release).
fn system_layout(layout: Layout) -> Layout {
    if layout.size() < HUGE_PAGE {
        return layout;
    }
    Layout::from_size_align(layout.size(), layout.align().max(HUGE_PAGE)).unwrap_or(layout)
}

// SAFETY: every block is taken from and given back to `System` with the
// same layout (`system_layout` of the caller's), which is at least as
// aligned as the caller asked and of the size asked; `advise` only reads a
// block's address and size.
unsafe impl GlobalAlloc for HugePageAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: `layout` has a non-zero size (the caller's contract), and so
        // has `system_layout`'s.
        let p = unsafe { System.alloc(system_layout(layout)) };
        advise(p, layout.size());
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as for `alloc`.
        let p = unsafe { System.alloc_zeroed(system_layout(layout)) };
        advise(p, layout.size());
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System` with `system_layout(layout)`.
        unsafe { System.dealloc(ptr, system_layout(layout)) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if layout.size() < HUGE_PAGE && new_size < HUGE_PAGE {
            // SAFETY: `ptr` came from `System` with `layout` (small: unchanged),
            // and the new block stays small.
            return unsafe { System.realloc(ptr, layout, new_size) };
        }
        // Into a block of the new size's layout, as `GlobalAlloc::realloc`
        // does by default.
        let Ok(new_layout) = Layout::from_size_align(new_size, layout.align()) else {
            return std::ptr::null_mut();
        };
        // SAFETY: `new_layout` has a non-zero size (the caller's contract).
        let p = unsafe { self.alloc(new_layout) };
        if !p.is_null() {
            // SAFETY: both blocks are live and distinct, and each holds at
            // least the bytes copied; `ptr` is this allocator's, of `layout`.
            unsafe {
                std::ptr::copy_nonoverlapping(ptr, p, layout.size().min(new_size));
                self.dealloc(ptr, layout);
            }
        }
        p
    }
}

/// Asks the kernel to back the whole huge pages inside the block at `p` of
/// `size` bytes with huge pages. Advice only: it changes how the memory is
/// backed, never what it holds, and its failure (no transparent huge pages
/// here) changes nothing, so it is ignored.
fn advise(p: *mut u8, size: usize) {
    if p.is_null() || size < HUGE_PAGE {
        return;
    }
    let start = (p as usize).next_multiple_of(HUGE_PAGE);
    let end = (p as usize + size) / HUGE_PAGE * HUGE_PAGE;
    if end > start {
        // SAFETY: `start..end` lies inside the block just allocated (it is
        // the block rounded inwards to huge-page boundaries), which this
        // program owns; MADV_HUGEPAGE does not change its contents.
        unsafe {
            libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::HUGE_PAGE;

    /// The flags of the mapping that holds address `at`, from the kernel's
    /// account of this process's memory.
    fn mapping_flags(at: usize) -> Option<String> {
        let smaps = std::fs::read_to_string("/proc/self/smaps").ok()?;
        let mut inside = false;
        for line in smaps.lines() {
            let range = line.split_whitespace().next().unwrap_or("");
            if let Some((a, b)) = range.split_once('-') {
                if let (Ok(a), Ok(b)) = (usize::from_str_radix(a, 16), usize::from_str_radix(b, 16))
                {
                    inside = (a..b).contains(&at);
                    continue;
                }
            }
            if inside {
                if let Some(flags) = line.strip_prefix("VmFlags:") {
                    return Some(flags.trim().to_string());
                }
            }
        }
        None
    }

    /// A vector grown past a huge page moves to a block that starts on one,
    /// and keeps its bytes on the way up and back down.
    #[test]
    fn a_growing_block_moves_onto_a_huge_page_and_keeps_its_bytes() {
        let pattern = |i: usize| (i * 7 + i / 4096) as u8;
        let mut v: Vec<u8> = (0..HUGE_PAGE / 2).map(pattern).collect();
        v.reserve_exact(3 * HUGE_PAGE);
        assert_eq!(
            v.as_ptr() as usize % HUGE_PAGE,
            0,
            "a large block is aligned"
        );
        v.extend((HUGE_PAGE / 2..3 * HUGE_PAGE).map(pattern));
        v.truncate(HUGE_PAGE / 4);
        v.shrink_to_fit();
        assert_eq!(v.capacity(), HUGE_PAGE / 4);
        assert!(v.iter().enumerate().all(|(i, &b)| b == pattern(i)));
        let small: Vec<u64> = vec![1; 1000];
        assert_eq!(small.iter().sum::<u64>(), 1000);
    }

    /// The kernel records the advice on a large block's mapping (`hg`), where
    /// it has transparent huge pages at all.
    #[test]
    fn a_large_block_is_advised_to_take_huge_pages() {
        let v = vec![0u8; 3 * HUGE_PAGE];
        let at = v.as_ptr() as usize + HUGE_PAGE;
        let flags = mapping_flags(at).expect("the block's mapping in /proc/self/smaps");
        if std::path::Path::new("/sys/kernel/mm/transparent_hugepage").exists() {
            assert!(flags.split(' ').any(|f| f == "hg"), "flags {flags}");
        } else {
            eprintln!("no transparent huge pages in this kernel: nothing to advise");
        }
        drop(v);
    }
}

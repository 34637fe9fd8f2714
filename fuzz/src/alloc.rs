//! A counting global allocator, so that "exhausts memory" is a crasher like a panic.
//!
//! Every allocation adds to a live-byte counter. When a cap is armed ([`arm`]) and an allocation
//! would take the live heap over it, the allocator calls the registered hook *before* asking the
//! system for the memory: the driver's hook saves the current input as an `oom` crasher and exits.
//! Without this, a reader that trusts a length field (`Vec::with_capacity(count)`) either aborts
//! the process with nothing saved or swaps the machine to death.
//!
//! A binary or test opts in with:
//! ```text
//! #[global_allocator]
//! static ALLOC: wedge_fuzz::alloc::CountingAlloc = wedge_fuzz::alloc::CountingAlloc;
//! ```
//! Without it, [`installed`] is false and the memory check is simply off.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicPtr, AtomicUsize, Ordering};

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
/// 0 = no cap.
static CAP: AtomicUsize = AtomicUsize::new(0);
static SEEN_ALLOCATION: AtomicBool = AtomicBool::new(false);
/// Set by the first allocation over the cap, so that only one thread runs the hook.
static TRIPPED: AtomicBool = AtomicBool::new(false);
/// `fn(requested_live_bytes)`; never returns in the driver (it exits).
static HOOK: AtomicPtr<()> = AtomicPtr::new(std::ptr::null_mut());

/// The allocator: the system allocator plus the live-byte count and the cap check.
pub struct CountingAlloc;

impl CountingAlloc {
    #[inline]
    fn grow(size: usize) {
        let live = LIVE.fetch_add(size, Ordering::Relaxed) + size;
        PEAK.fetch_max(live, Ordering::Relaxed);
        let cap = CAP.load(Ordering::Relaxed);
        if cap != 0 && live > cap && !TRIPPED.swap(true, Ordering::SeqCst) {
            // Disarm first: the hook allocates (file names, messages) and must not re-enter.
            CAP.store(0, Ordering::SeqCst);
            let hook = HOOK.load(Ordering::SeqCst);
            if !hook.is_null() {
                // SAFETY: only `set_hook` stores here, always a `fn(usize)`.
                let f: fn(usize) = unsafe { std::mem::transmute::<*mut (), fn(usize)>(hook) };
                f(live);
            }
        }
    }
}

// SAFETY: every call is forwarded to `System` unchanged; only counters are updated around it.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        SEEN_ALLOCATION.store(true, Ordering::Relaxed);
        Self::grow(layout.size());
        System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        Self::grow(layout.size());
        System.alloc_zeroed(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        System.dealloc(ptr, layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > layout.size() {
            Self::grow(new_size - layout.size());
        } else {
            LIVE.fetch_sub(layout.size() - new_size, Ordering::Relaxed);
        }
        System.realloc(ptr, layout, new_size)
    }
}

/// Whether [`CountingAlloc`] is this program's global allocator (it has seen an allocation).
pub fn installed() -> bool {
    // Make sure at least one allocation has happened through whatever allocator is installed.
    drop(std::hint::black_box(Box::new(0u8)));
    SEEN_ALLOCATION.load(Ordering::Relaxed)
}

/// Register the function called once when the cap is exceeded (with the live bytes requested).
pub fn set_hook(f: fn(usize)) {
    HOOK.store(f as *mut (), Ordering::SeqCst);
}

/// Treat a live heap above `cap_bytes` as a crasher (0 disarms).
pub fn arm(cap_bytes: usize) {
    CAP.store(cap_bytes, Ordering::SeqCst);
}

/// Bytes currently allocated.
pub fn live_bytes() -> usize {
    LIVE.load(Ordering::Relaxed)
}

/// Highest live heap seen since the last [`reset_peak`].
pub fn peak_bytes() -> usize {
    PEAK.load(Ordering::Relaxed)
}

pub fn reset_peak() {
    PEAK.store(LIVE.load(Ordering::Relaxed), Ordering::Relaxed);
}

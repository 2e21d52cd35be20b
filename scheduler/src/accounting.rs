//! An accounting global allocator: every allocation is attributed to the code
//! running on the calling thread (the executive or one of its tasks).
//!
//! Install it in a binary or test with
//! `#[global_allocator] static A: AccountingAllocator = AccountingAllocator;`.
//! Counting is per thread, so tests running in parallel do not disturb each
//! other, and threads that never call [`set_slot`] are not counted at all.
//! The heap's live bytes and their high-water mark are kept for the whole
//! process (every thread).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicU64, Ordering};

static LIVE: AtomicU64 = AtomicU64::new(0);
static PEAK: AtomicU64 = AtomicU64::new(0);

#[inline]
fn live_grows(by: u64) {
    let now = LIVE.fetch_add(by, Ordering::Relaxed) + by;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

#[inline]
fn live_shrinks(by: u64) {
    LIVE.fetch_sub(by, Ordering::Relaxed);
}

/// Heap bytes in use now, every thread (0 unless this allocator is the
/// global one).
pub fn heap_live_bytes() -> u64 {
    LIVE.load(Ordering::Relaxed)
}

/// The most heap bytes in use at once since the start or the last
/// [`reset_heap_peak`].
pub fn heap_peak_bytes() -> u64 {
    PEAK.load(Ordering::Relaxed)
}

/// Start the high-water mark again from what is in use now.
pub fn reset_heap_peak() {
    PEAK.store(LIVE.load(Ordering::Relaxed), Ordering::Relaxed);
}

use crate::MAX_TASKS;

/// Slot 0 is the executive, slot `1 + i` task `i`, then the application's
/// housekeeping between frames (logging, progress display) and the simulated
/// world (physics and sensor twins, which stand for the outside world and
/// are not on-board work); both are kept apart from the periodic work.
pub const SLOTS: usize = MAX_TASKS + 3;
/// The housekeeping slot.
pub const HOUSEKEEPING: u16 = (MAX_TASKS + 1) as u16;
/// The simulated world's slot.
pub const WORLD: u16 = (MAX_TASKS + 2) as u16;
const UNTRACKED: u16 = u16::MAX;

thread_local! {
    static CURRENT: Cell<u16> = const { Cell::new(UNTRACKED) };
    static COUNTS: [Cell<u64>; SLOTS] = const { [const { Cell::new(0) }; SLOTS] };
    static BYTES: [Cell<u64>; SLOTS] = const { [const { Cell::new(0) }; SLOTS] };
}

/// Wraps the system allocator and counts.
pub struct AccountingAllocator;

/// Allocations of at least this many bytes in a counted slot are traced
/// (`u64::MAX`: none).
static TRACE_OVER: AtomicU64 = AtomicU64::new(u64::MAX);
/// Allocations traced so far, every thread.
static TRACED: AtomicU64 = AtomicU64::new(0);

thread_local! {
    /// Set while a trace is written: its own allocations are not traced.
    static TRACING: Cell<bool> = const { Cell::new(false) };
}

/// From now on, print the slot, the size and a backtrace to stderr for
/// every allocation of at least `bytes` counted in a slot (`None`: stop).
/// For finding which allocation made a task's run ask for more than its
/// memory budget; the cost when off is one relaxed load per allocation.
pub fn trace_allocations_over(bytes: Option<u64>) {
    TRACE_OVER.store(bytes.unwrap_or(u64::MAX), Ordering::Relaxed);
}

/// Allocations traced since the start, every thread.
pub fn traced_allocations() -> u64 {
    TRACED.load(Ordering::Relaxed)
}

#[cold]
fn trace(slot: usize, size: usize) {
    if TRACING.try_with(|t| t.replace(true)).unwrap_or(true) {
        return;
    }
    TRACED.fetch_add(1, Ordering::Relaxed);
    eprintln!(
        "allocation of {size} bytes in slot {slot}:\n{}",
        std::backtrace::Backtrace::force_capture()
    );
    let _ = TRACING.try_with(|t| t.set(false));
}

#[inline]
fn count(size: usize) {
    // try_with: during thread teardown the slots may be gone; then don't count.
    let _ = CURRENT.try_with(|c| {
        let slot = c.get() as usize;
        if slot < SLOTS {
            if size as u64 >= TRACE_OVER.load(Ordering::Relaxed) {
                trace(slot, size);
            }
            let _ = COUNTS.try_with(|n| n[slot].set(n[slot].get() + 1));
            let _ = BYTES.try_with(|b| b[slot].set(b[slot].get() + size as u64));
        }
    });
}

// SAFETY: every call is forwarded unchanged to the system allocator; counting
// touches only const-initialised thread-locals, which never allocate.
unsafe impl GlobalAlloc for AccountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count(layout.size());
        // SAFETY: forwarded with the caller's layout.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            live_grows(layout.size() as u64);
        }
        p
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count(layout.size());
        // SAFETY: forwarded with the caller's layout.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            live_grows(layout.size() as u64);
        }
        p
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count(new_size);
        // SAFETY: forwarded with the caller's pointer and layout.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            live_grows(new_size as u64);
            live_shrinks(layout.size() as u64);
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        live_shrinks(layout.size() as u64);
        // SAFETY: forwarded with the caller's pointer and layout.
        unsafe { System.dealloc(ptr, layout) }
    }
}

/// Attribute this thread's allocations to `slot` from now on.
#[inline]
pub fn set_slot(slot: u16) {
    let _ = CURRENT.try_with(|c| c.set(slot));
}

/// Stop counting on this thread.
pub fn untrack() {
    set_slot(UNTRACKED);
}

/// Allocations (including reallocations) counted on this thread in `slot`.
pub fn allocations(slot: usize) -> u64 {
    COUNTS.with(|n| n.get(slot).map_or(0, Cell::get))
}

/// Bytes requested on this thread in `slot`.
pub fn bytes(slot: usize) -> u64 {
    BYTES.with(|b| b.get(slot).map_or(0, Cell::get))
}

/// Count, on this thread in its current slot, allocations made on another
/// thread on its behalf (a [`crate::coprocessor`]'s batch).
pub fn charge(allocations: u64, bytes: u64) {
    let slot = CURRENT.with(Cell::get) as usize;
    if slot < SLOTS {
        COUNTS.with(|n| n[slot].set(n[slot].get() + allocations));
        BYTES.with(|b| b[slot].set(b[slot].get() + bytes));
    }
}

/// All allocations counted on this thread, every slot.
pub fn total_allocations() -> u64 {
    COUNTS.with(|n| n.iter().map(Cell::get).sum())
}

/// Run `f` counting this thread's allocations, and return how many it made:
/// how a test proves that a piece of code allocates nothing (the
/// accounting allocator must be the binary's global allocator).
pub fn allocations_in<R>(f: impl FnOnce() -> R) -> (R, u64) {
    let previous = CURRENT.with(Cell::get);
    set_slot(0);
    let before = allocations(0);
    let r = f();
    let made = allocations(0) - before;
    set_slot(previous);
    (r, made)
}

/// Zero this thread's counters.
pub fn reset() {
    COUNTS.with(|n| n.iter().for_each(|c| c.set(0)));
    BYTES.with(|b| b.iter().for_each(|c| c.set(0)));
}

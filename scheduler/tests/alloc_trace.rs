//! Tracing large allocations: only those at or over the threshold, only in
//! a counted slot, and none once tracing is off. One test: the threshold is
//! the process's.

use std::hint::black_box;

use speleo_scheduler::accounting::{self, AccountingAllocator};

#[global_allocator]
static ALLOC: AccountingAllocator = AccountingAllocator;

const MIB: usize = 1 << 20;

#[test]
fn allocations_over_the_threshold_in_a_counted_slot_are_traced_and_no_others() {
    accounting::trace_allocations_over(Some(MIB as u64));
    let before = accounting::traced_allocations();
    // Not in a slot: not counted, not traced.
    black_box(vec![0u8; 2 * MIB]);
    assert_eq!(accounting::traced_allocations(), before);
    accounting::set_slot(3);
    black_box(vec![1u8; 1024]);
    assert_eq!(accounting::traced_allocations(), before);
    black_box(vec![1u8; 2 * MIB]);
    assert_eq!(accounting::traced_allocations(), before + 1);
    // A vector grown past the threshold: the reallocation is traced too.
    let mut v: Vec<u8> = Vec::with_capacity(MIB / 2);
    v.resize(MIB + 1, 7);
    black_box(&v);
    assert_eq!(accounting::traced_allocations(), before + 2);
    accounting::trace_allocations_over(None);
    black_box(vec![1u8; 2 * MIB]);
    assert_eq!(accounting::traced_allocations(), before + 2);
    accounting::untrack();
}

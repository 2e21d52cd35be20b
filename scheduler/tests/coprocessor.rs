//! A task that lends batches of its work to a coprocessor: the same results
//! as doing them itself, nothing allocated by the hand-over, and the
//! worker's allocations charged to the task's runs.

use speleo_scheduler::accounting::{self, AccountingAllocator};
use speleo_scheduler::coprocessor::{Batch, Coprocessor, FrameSync};
use speleo_scheduler::realtime::StdPlatform;
use speleo_scheduler::{
    AnytimeSpec, Context, Enforcement, Executive, OverrunPolicy, RateGroup, Schedule, StepResult,
    Task, TaskSpec, VirtualClock,
};

#[global_allocator]
static ALLOC: AccountingAllocator = AccountingAllocator;

/// The job: a hash chain over its units; it allocates a scratch buffer of
/// `scratch` bytes a batch when asked to.
struct Chain {
    acc: u64,
    scratch: usize,
}

fn chain(c: &mut Chain, units: u32) {
    if c.scratch > 0 {
        let v = vec![1u8; c.scratch];
        c.acc = c.acc.wrapping_add(v.iter().map(|&b| b as u64).sum::<u64>());
    }
    for k in 0..units as u64 {
        c.acc = c.acc.rotate_left(7) ^ k.wrapping_mul(0x9e37_79b9_7f4a_7c15);
    }
}

/// Lends a batch of `units` at the end of each step and takes it back at
/// the start of the next.
struct Lender {
    home: Option<Box<Chain>>,
    cp: Coprocessor<Chain>,
    units: u32,
    batches: Vec<Batch>,
}

impl Task<()> for Lender {
    fn run(&mut self, _: &mut (), _: &Context) {}
    fn step(&mut self, _: &mut (), _: &Context, _quantum: u32) -> StepResult {
        if let Some((job, batch)) = self.cp.join() {
            accounting::charge(batch.allocations, batch.bytes);
            if self.batches.len() < self.batches.capacity() {
                self.batches.push(batch);
            }
            self.home = Some(job);
        }
        if let Some(job) = self.home.take() {
            if let Err(job) = self.cp.lend(job, self.units) {
                self.home = Some(job);
            }
        }
        StepResult::Idle
    }
}

fn run(frames: u64, scratch: usize) -> (u64, u64, Vec<Batch>) {
    let cp = Coprocessor::spawn("worker", 5, chain).expect("thread");
    let sync: FrameSync = cp.sync();
    let mut lender = Lender {
        home: Some(Box::new(Chain { acc: 1, scratch })),
        cp,
        units: 1000,
        batches: Vec::with_capacity(frames as usize),
    };
    let spec = TaskSpec::anytime(
        "lender",
        RateGroup::EVERY_FRAME,
        5_000,
        OverrunPolicy::Skip,
        AnytimeSpec {
            quantum: 1,
            steps: 1,
            window_us: 5_000,
        },
    );
    let schedule = Schedule::build(10_000, 500, &[spec]).expect("fits");
    let mut tasks: heapless::Vec<&mut dyn Task<()>, { speleo_scheduler::MAX_TASKS }> =
        heapless::Vec::new();
    let _ = tasks.push(&mut lender);
    let mut exec = Executive::new(
        schedule,
        tasks,
        StdPlatform,
        VirtualClock::new(10_000),
        Enforcement::CountOnly,
    )
    .expect("valid");
    for _ in 0..frames {
        sync.wait_idle();
        exec.run_frame(&mut ());
    }
    let alloc_max = exec.stats()[0].alloc_bytes_max_run;
    drop(exec);
    let job = lender
        .cp
        .join()
        .map(|(j, _)| j)
        .or(lender.home)
        .expect("job");
    (job.acc, alloc_max, lender.batches)
}

#[test]
fn batches_lent_frame_by_frame_give_the_same_result_as_work_done_in_place() {
    let (acc, _, batches) = run(20, 0);
    let mut local = Chain { acc: 1, scratch: 0 };
    for _ in 0..20 {
        chain(&mut local, 1000);
    }
    assert_eq!(acc, local.acc);
    // Nineteen taken back within the frames, the last one after them.
    assert_eq!(batches.len(), 19);
}

#[test]
fn the_hand_over_allocates_nothing_and_the_workers_allocations_are_the_tasks() {
    let (_, quiet, batches) = run(10, 0);
    assert_eq!(quiet, 0, "lending and joining allocated");
    assert!(batches.iter().all(|b| b.allocations == 0));
    let (_, busy, batches) = run(10, 4096);
    assert!(batches
        .iter()
        .all(|b| b.allocations == 1 && b.bytes == 4096));
    assert_eq!(busy, 4096, "the worker's scratch is charged to the run");
}

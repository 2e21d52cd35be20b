//! Executive behaviour: rate groups, anytime steps, overrun policies and the
//! zero-allocation guarantee after start-up.

use std::cell::Cell;

use speleo_scheduler::accounting::{self, AccountingAllocator};
use speleo_scheduler::mailbox::{Fifo, Latest};
use speleo_scheduler::realtime::StdPlatform;
use speleo_scheduler::{
    AnytimeSpec, Context, Enforcement, Executive, Mode, OverrunPolicy, Platform, RateGroup,
    Schedule, StepResult, Task, TaskSpec, VirtualClock,
};

#[global_allocator]
static ALLOC: AccountingAllocator = AccountingAllocator;

#[derive(Default)]
struct Bus {
    counter: Latest<u64>,
    doubled: Latest<u64>,
    log: Fifo<u64, 64>,
    motor: Latest<f64>,
    work_done: u64,
    /// Frames the producer was left out of, as it was told.
    skips_noticed: u64,
}

struct Producer;
impl Task<Bus> for Producer {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let n = bus.counter.get().map_or(0, |s| s.value) + 1;
        bus.counter.publish(cx.time_ns, n);
        bus.log.push(n);
    }
    fn skipped(&mut self, bus: &mut Bus) {
        bus.skips_noticed += 1;
    }
}

struct Doubler {
    seen: u64,
    degraded: bool,
}
impl Task<Bus> for Doubler {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        if let Some(s) = bus.counter.newer_than(self.seen) {
            self.seen = s.seq;
            let factor = if self.degraded { 1 } else { 2 };
            bus.doubled.publish(cx.time_ns, s.value * factor);
        }
        while bus.log.pop().is_some() {}
    }
    fn set_degraded(&mut self, on: bool) {
        self.degraded = on;
    }
    fn retract(&mut self, bus: &mut Bus) {
        bus.doubled.retract();
    }
}

/// Anytime: counts down a fixed amount of work, `quantum` units per step.
struct Countdown {
    remaining: u64,
}
impl Task<Bus> for Countdown {
    fn run(&mut self, _bus: &mut Bus, _cx: &Context) {
        if self.remaining == 0 {
            self.remaining = 1000;
        }
    }
    fn step(&mut self, bus: &mut Bus, _cx: &Context, quantum: u32) -> StepResult {
        let q = (quantum as u64).min(self.remaining);
        self.remaining -= q;
        bus.work_done += q;
        if self.remaining == 0 {
            StepResult::Idle
        } else {
            StepResult::Continue
        }
    }
}

struct MotorOut;
impl Task<Bus> for MotorOut {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let cmd = if cx.mode == Mode::Safe { 0.0 } else { 1.5 };
        bus.motor.publish(cx.time_ns, cmd);
    }
}

fn specs() -> Vec<TaskSpec> {
    vec![
        TaskSpec::periodic(
            "producer",
            RateGroup::EVERY_FRAME,
            1000,
            OverrunPolicy::Skip,
        )
        .safe(),
        TaskSpec::periodic(
            "doubler",
            RateGroup::new(2, 1),
            1000,
            OverrunPolicy::ReuseLast,
        ),
        TaskSpec::anytime(
            "countdown",
            RateGroup::new(10, 3),
            100,
            OverrunPolicy::Degrade,
            AnytimeSpec {
                quantum: 7,
                steps: 20,
                window_us: 2000,
            },
        ),
        TaskSpec::periodic(
            "motor",
            RateGroup::EVERY_FRAME,
            100,
            OverrunPolicy::SafeMode,
        )
        .safe(),
    ]
}

/// The four test tasks, and an executive over them with the standard table.
struct Tasks {
    producer: Producer,
    doubler: Doubler,
    countdown: Countdown,
    motor: MotorOut,
}

impl Tasks {
    fn new() -> Self {
        Tasks {
            producer: Producer,
            doubler: Doubler {
                seen: 0,
                degraded: false,
            },
            countdown: Countdown { remaining: 0 },
            motor: MotorOut,
        }
    }

    fn executive<P: Platform>(
        &mut self,
        platform: P,
        enforcement: Enforcement,
    ) -> Executive<'_, Bus, P, VirtualClock> {
        let schedule = Schedule::build(10_000, 500, &specs()).expect("fits");
        let mut tasks: heapless::Vec<&mut dyn Task<Bus>, 32> = heapless::Vec::new();
        let _ = tasks.push(&mut self.producer);
        let _ = tasks.push(&mut self.doubler);
        let _ = tasks.push(&mut self.countdown);
        let _ = tasks.push(&mut self.motor);
        Executive::new(
            schedule,
            tasks,
            platform,
            VirtualClock::new(10_000),
            enforcement,
        )
        .expect("executive")
    }
}

#[test]
fn ten_thousand_frames_allocate_nothing_after_start_up() {
    let mut bus = Bus::default();
    let mut tasks = Tasks::new();
    let mut exec = tasks.executive(StdPlatform, Enforcement::CountOnly);
    accounting::reset();
    accounting::set_slot(0);
    for _ in 0..10_000 {
        exec.run_frame(&mut bus);
        while exec.pop_event().is_some() {}
    }
    accounting::untrack();
    let total = accounting::total_allocations();
    assert_eq!(total, 0, "allocations after start-up");
    let stats = exec.stats();
    assert_eq!(stats[0].runs, 10_000);
    assert_eq!(stats[1].runs, 5_000);
    assert_eq!(stats[2].runs, 1_000);
    assert_eq!(bus.counter.get().map(|s| s.value), Some(10_000));
    assert_eq!(bus.doubled.get().map(|s| s.value), Some(20_000));
    assert_eq!(bus.motor.get().map(|s| s.value), Some(1.5));
}

#[test]
fn allocations_are_attributed_to_the_running_task() {
    struct Allocates;
    impl Task<Bus> for Allocates {
        fn run(&mut self, _bus: &mut Bus, _cx: &Context) {
            let v: Vec<u8> = Vec::with_capacity(64);
            std::hint::black_box(v);
        }
    }
    let schedule = Schedule::build(
        10_000,
        0,
        &[
            TaskSpec::periodic("quiet", RateGroup::EVERY_FRAME, 100, OverrunPolicy::Skip),
            TaskSpec::periodic("leaky", RateGroup::EVERY_FRAME, 100, OverrunPolicy::Skip),
        ],
    )
    .expect("fits");
    let (mut q, mut l) = (MotorOut, Allocates);
    let mut tasks: heapless::Vec<&mut dyn Task<Bus>, 32> = heapless::Vec::new();
    let _ = tasks.push(&mut q);
    let _ = tasks.push(&mut l);
    let mut exec = Executive::new(
        schedule,
        tasks,
        StdPlatform,
        VirtualClock::new(10_000),
        Enforcement::CountOnly,
    )
    .expect("executive");
    let mut bus = Bus::default();
    accounting::reset();
    accounting::set_slot(0);
    for _ in 0..10 {
        exec.run_frame(&mut bus);
    }
    accounting::untrack();
    assert_eq!(accounting::allocations(0), 0);
    assert_eq!(accounting::allocations(1), 0);
    assert_eq!(accounting::allocations(2), 10);
    assert_eq!(accounting::bytes(2), 640);
}

/// A platform whose clock advances by a scripted amount per reading, so that
/// overruns can be produced deterministically.
struct ScriptedPlatform {
    now: Cell<u64>,
    /// Duration the next measured run takes, by task slot.
    durations: Cell<[u64; 8]>,
    /// Of which the thread was preempted (not on its CPU clock).
    preempted: Cell<[u64; 8]>,
    /// The thread's CPU clock.
    cpu: Cell<u64>,
    slot: Cell<u16>,
}
impl ScriptedPlatform {
    fn new() -> Self {
        ScriptedPlatform {
            now: Cell::new(0),
            durations: Cell::new([0; 8]),
            preempted: Cell::new([0; 8]),
            cpu: Cell::new(0),
            slot: Cell::new(0),
        }
    }
}
impl Platform for &ScriptedPlatform {
    fn now_ns(&self) -> u64 {
        // A reading taken while a task runs (its end) advances by its duration.
        let slot = self.slot.get() as usize;
        if slot != 0 {
            self.now.set(self.now.get() + self.durations.get()[slot]);
        }
        self.now.get()
    }
    fn thread_cpu_ns(&self) -> Option<u64> {
        // Read right after `now_ns` at a run's end: the run's time on CPU.
        let slot = self.slot.get() as usize;
        if slot != 0 {
            let on_cpu = self.durations.get()[slot] - self.preempted.get()[slot];
            self.cpu.set(self.cpu.get() + on_cpu);
        }
        Some(self.cpu.get())
    }
    fn enter(&self, slot: u16) {
        self.slot.set(slot);
    }
}

/// Per task: (runs, overruns, skipped, retracted).
type Counts = Vec<(u64, u64, u64, u64)>;

fn run_policy_case(overrunning_slot: usize, frames: u64) -> (Bus, Counts, Mode) {
    let platform = ScriptedPlatform::new();
    let mut d = [50_000u64; 8];
    d[overrunning_slot] = 5_000_000; // 5 ms, over every budget
    platform.durations.set(d);
    let mut bus = Bus::default();
    let mut tasks = Tasks::new();
    let mut exec = tasks.executive(&platform, Enforcement::Enforce);
    for _ in 0..frames {
        exec.run_frame(&mut bus);
    }
    let stats = exec
        .stats()
        .iter()
        .map(|s| (s.runs, s.overruns, s.skipped, s.retracted))
        .collect();
    let mode = exec.mode();
    (bus, stats, mode)
}

#[test]
fn skip_policy_drops_the_next_run() {
    let (bus, stats, mode) = run_policy_case(1, 10);
    // producer overruns every run and skips every other one.
    assert_eq!(stats[0], (5, 5, 5, 0));
    assert_eq!(bus.counter.get().map(|s| s.value), Some(5));
    assert_eq!(mode, Mode::Nominal);
}

#[test]
fn a_skipped_task_is_told_so() {
    let (bus, stats, _) = run_policy_case(1, 10);
    assert_eq!(bus.skips_noticed, stats[0].2);
}

#[test]
fn replay_takes_the_recorded_overruns_instead_of_measuring() {
    let platform = ScriptedPlatform::new();
    // The doubler's runs take 5 ms, but the record says only the
    // producer overran, in frame 0.
    let mut d = [50_000u64; 8];
    d[2] = 5_000_000;
    platform.durations.set(d);
    let mut bus = Bus::default();
    let mut tasks = Tasks::new();
    let mut exec = tasks.executive(&platform, Enforcement::Replay);
    let mut overran = Vec::new();
    for frame in 0..4 {
        exec.replay_overruns(if frame == 0 { 1 } else { 0 });
        overran.push(exec.run_frame(&mut bus).overran);
    }
    assert_eq!(overran, [1, 0, 0, 0]);
    let producer = &exec.stats()[0];
    assert_eq!(
        (producer.runs, producer.overruns, producer.skipped),
        (3, 1, 1)
    );
    assert_eq!(exec.stats()[1].overruns, 0, "measured, not recorded");
    assert_eq!(bus.skips_noticed, 1);
}

#[test]
fn reuse_last_withdraws_the_late_output() {
    let (bus, stats, _) = run_policy_case(2, 10);
    assert_eq!(stats[1], (5, 5, 0, 5));
    // Every output was withdrawn: consumers see none.
    assert!(bus.doubled.get().is_none());
}

#[test]
fn degrade_switches_the_task_to_its_reduced_mode() {
    let (bus, stats, _) = run_policy_case(3, 10);
    assert_eq!(stats[2].1, 1);
    // Doubler is unaffected; countdown did its fixed work despite the overrun.
    assert_eq!(bus.work_done, 140);
}

#[test]
fn safe_mode_stops_the_motors_and_keeps_the_sensors() {
    let (bus, stats, mode) = run_policy_case(4, 10);
    assert_eq!(mode, Mode::Safe);
    assert_eq!(bus.motor.get().map(|s| s.value), Some(0.0));
    // The producer (a sensor driver, safe) kept running every frame...
    assert_eq!(stats[0].0, 10);
    // ...the doubler (not safe) never ran: safe mode began in frame 0.
    assert_eq!(stats[1].0, 0);
    assert_eq!(stats[1].2, 5);
}

#[test]
fn count_only_changes_nothing() {
    let platform = ScriptedPlatform::new();
    platform.durations.set([5_000_000; 8]);
    let mut bus = Bus::default();
    let mut tasks = Tasks::new();
    let mut exec = tasks.executive(&platform, Enforcement::CountOnly);
    for _ in 0..20 {
        exec.run_frame(&mut bus);
    }
    assert_eq!(exec.mode(), Mode::Nominal);
    assert_eq!(exec.stats()[0].overruns, 20);
    assert_eq!(bus.counter.get().map(|s| s.value), Some(20));
    let mut logged = 0;
    while exec.pop_event().is_some() {
        logged += 1;
    }
    // 20 frames x 4 tasks, 10 a second logged.
    assert_eq!(logged, 10);
    assert!(exec.suppressed_events() > 0);
}

#[test]
fn anytime_work_is_a_fixed_amount_per_run() {
    // 20 steps of 7 units = 140 units per run, whatever the machine; in 14
    // frames the group (10, 3) runs in frames 3 and 13.
    let (bus, stats, _) = run_policy_case(0, 14);
    assert_eq!(stats[2].0, 2);
    assert_eq!(bus.work_done, 280);
}

#[test]
fn wrong_task_count_is_refused() {
    let schedule = Schedule::build(10_000, 500, &specs()).expect("fits");
    let mut p = Producer;
    let mut tasks: heapless::Vec<&mut dyn Task<Bus>, 32> = heapless::Vec::new();
    let _ = tasks.push(&mut p);
    assert!(Executive::new(
        schedule,
        tasks,
        StdPlatform,
        VirtualClock::new(10_000),
        Enforcement::CountOnly
    )
    .is_err());
}

#[test]
fn work_between_tasks_is_charged_to_no_task() {
    let platform = ScriptedPlatform::new();
    platform.durations.set([50_000u64; 8]);
    let mut bus = Bus::default();
    let mut tasks = Tasks::new();
    let mut exec = tasks.executive(&platform, Enforcement::Enforce);
    let mut called = Vec::new();
    for _ in 0..10 {
        exec.run_frame_with(&mut bus, &mut |i| {
            called.push(i);
            // The outside world takes 20 ms after the producer: over every
            // task's budget, but no task's time.
            if i == 0 {
                platform.now.set(platform.now.get() + 20_000_000);
            }
        });
    }
    let overruns: u64 = exec.stats().iter().map(|s| s.overruns).sum();
    assert_eq!(overruns, 0);
    assert_eq!(exec.mode(), Mode::Nominal);
    // Called after each task that ran, in order: producer and motor every
    // frame, the doubler every other frame, the countdown once in ten.
    let runs: u64 = exec.stats().iter().map(|s| s.runs).sum();
    assert_eq!(called.len() as u64, runs);
    assert_eq!(called.iter().filter(|&&i| i == 0).count(), 10);
    assert_eq!(called.iter().filter(|&&i| i == 1).count(), 5);
    assert_eq!(called.iter().filter(|&&i| i == 2).count(), 1);
    // Frame 0 runs the producer and the motor, frame 1 the doubler too.
    assert_eq!(&called[..5], &[0, 3, 0, 1, 3]);
}

#[test]
fn cpu_time_leaves_out_preemption() {
    let platform = ScriptedPlatform::new();
    platform
        .durations
        .set([50_000u64, 50_000, 5_000_000, 50_000, 50_000, 0, 0, 0]);
    // The doubler's 5 ms run was preempted for all but 120 us of it.
    platform.preempted.set([0, 0, 4_880_000, 0, 0, 0, 0, 0]);
    let mut bus = Bus::default();
    let mut tasks = Tasks::new();
    let mut exec = tasks.executive(&platform, Enforcement::CountOnly);
    for _ in 0..10 {
        exec.run_frame(&mut bus);
    }
    let doubler = &exec.stats()[1];
    // Budgets are judged on the wall clock...
    assert_eq!(doubler.overruns, doubler.runs);
    assert!((doubler.max_us() - 5000.0).abs() < 5000.0 * 0.07);
    // ...and the CPU clock shows what the task itself took.
    let cpu = doubler.cpu_us().expect("measured");
    assert!((cpu.max_us - 120.0).abs() < 120.0 * 0.07, "{cpu:?}");
    let producer = exec.stats()[0].cpu_us().expect("measured");
    assert!(
        (producer.p999_us - 50.0).abs() < 50.0 * 0.07,
        "{producer:?}"
    );
}

#[test]
fn the_real_platform_measures_cpu_time() {
    let mut bus = Bus::default();
    let mut tasks = Tasks::new();
    let mut exec = tasks.executive(StdPlatform, Enforcement::CountOnly);
    for _ in 0..4 {
        exec.run_frame(&mut bus);
    }
    for st in exec.stats().iter().filter(|s| s.runs > 0) {
        let cpu = st.cpu_us().expect("the thread's CPU clock is read");
        assert!(
            cpu.max_us <= st.max_us() * 1.07 + 1.0,
            "{cpu:?} vs {}",
            st.max_us()
        );
    }
}

#[test]
fn allocations_in_counts_what_its_closure_allocates_and_puts_the_slot_back() {
    accounting::set_slot(4);
    let (v, made) = accounting::allocations_in(|| std::hint::black_box(vec![1u8; 100]));
    assert_eq!((v.len(), made), (100, 1));
    let ((), none) = accounting::allocations_in(|| ());
    assert_eq!(none, 0);
    let before = accounting::allocations(4);
    std::hint::black_box(vec![2u8; 10]);
    assert_eq!(accounting::allocations(4), before + 1, "slot 4 again");
    accounting::untrack();
}

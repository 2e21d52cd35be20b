//! Dispatch overhead of the executive per task per frame: 17 trivial tasks
//! (the size of copper-rs's published chain), against the same 17 calls made
//! directly in a loop with no executive, in the same run; with the real
//! platform (wall and thread CPU clock a run) and with the wall clock only.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use speleo_scheduler::realtime::{monotonic_ns, StdPlatform};
use speleo_scheduler::{
    Context, Enforcement, Executive, Mode, OverrunPolicy, Platform, RateGroup, Schedule, Task,
    TaskSpec, VirtualClock,
};

/// The monotonic clock alone: what the CPU clock's reads cost.
struct WallOnly;
impl Platform for WallOnly {
    fn now_ns(&self) -> u64 {
        monotonic_ns()
    }
}

const TASKS: usize = 17;

struct Bus {
    value: u64,
}

struct Add(u64);
impl Task<Bus> for Add {
    #[inline(never)]
    fn run(&mut self, bus: &mut Bus, _cx: &Context) {
        bus.value = bus.value.wrapping_add(self.0);
    }
}

/// One frame of `TASKS` trivial tasks through the executive on `platform`.
fn bench_executive<P: Platform>(
    g: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    schedule: &Schedule,
    platform: P,
    bus: &mut Bus,
) {
    let mut objs: Vec<Add> = (0..TASKS as u64).map(Add).collect();
    let mut tasks: heapless::Vec<&mut dyn Task<Bus>, 32> = heapless::Vec::new();
    for t in objs.iter_mut() {
        let _ = tasks.push(t);
    }
    let mut exec = Executive::new(
        schedule.clone(),
        tasks,
        platform,
        VirtualClock::new(10_000),
        Enforcement::CountOnly,
    )
    .expect("executive");
    g.bench_function(name, |b| {
        b.iter(|| exec.run_frame(std::hint::black_box(&mut *bus)))
    });
}

fn bench(c: &mut Criterion) {
    let specs: Vec<TaskSpec> = (0..TASKS)
        .map(|i| {
            TaskSpec::periodic(
                &format!("t{i}"),
                RateGroup::EVERY_FRAME,
                500,
                OverrunPolicy::Skip,
            )
        })
        .collect();
    let schedule = Schedule::build(10_000, 0, &specs).expect("fits");
    let mut bus = Bus { value: 0 };
    let mut g = c.benchmark_group("dispatch");
    g.throughput(Throughput::Elements(TASKS as u64));
    bench_executive(
        &mut g,
        "executive_17_tasks_per_frame",
        &schedule,
        StdPlatform,
        &mut bus,
    );
    bench_executive(
        &mut g,
        "executive_17_tasks_per_frame_wall_clock_only",
        &schedule,
        WallOnly,
        &mut bus,
    );
    let mut direct: Vec<Add> = (0..TASKS as u64).map(Add).collect();
    let cx = Context {
        frame: 0,
        time_ns: 0,
        minor_frame_ns: 10_000_000,
        mode: Mode::Nominal,
        degraded: false,
    };
    g.bench_function("direct_calls_17_tasks", |b| {
        b.iter_batched_ref(
            || (),
            |_| {
                for t in direct.iter_mut() {
                    let t: &mut dyn Task<Bus> = std::hint::black_box(t);
                    t.run(&mut bus, &cx);
                }
            },
            BatchSize::SmallInput,
        )
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

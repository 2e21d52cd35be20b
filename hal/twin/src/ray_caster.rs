//! Aims and casts the LiDAR twin's firings, on a helper thread while the
//! rover's software runs and on the calling thread when it comes back.
//!
//! The rays are independent, so which thread casts which changes nothing
//! in the result: the packets are the same bytes with one thread or two.
//! Casting is most of what the simulated world costs (the HDL-32E's
//! ~580,000 rays a simulated second), and on the rover that work is the
//! sensor's own, not the computer's, so the simulation spends the second
//! core on it.
//!
//! A batch of firings is cut into chunks that either thread claims in
//! turn, and a chunk's rays are aimed where they are cast, from the
//! firing's pose. `publish` hands the helper each chunk as soon as its
//! firings are aimed (while the physics steps on), and returns at once;
//! `collect` casts the chunks nobody has claimed yet, waits for the
//! helper's last one and hands each firing's returns over in order.
//! Between the two the calling thread is free for other work. The helper
//! lives as long as the caster; chunks and signals are made at start-up,
//! so nothing allocates per batch.

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;

use crate::lidar::LidarWorld;
use speleo_hal::hdl32e::LASERS;
use speleo_physics::quat;
use speleo_physics::terrain::Material;

/// What a ray met: distance, cosine of the incidence angle and surface.
pub type RayReturn = Option<(f64, f64, Material)>;

/// Where one firing's lasers point: the lasers that fire, the sensor's
/// position at the first and after the last laser, its orientation
/// (sensor to world) and the head's azimuth as (sin, cos).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Aim {
    pub live: u32,
    pub start: [f64; 3],
    pub end: [f64; 3],
    pub rotation: [[f64; 3]; 3],
    pub azimuth: (f64, f64),
}

/// The head's fixed geometry: each laser's elevation as (cos, sin) and its
/// azimuth offset within a firing as (sin, cos).
#[derive(Clone, Copy, Debug)]
pub struct Head {
    pub elevation: [(f64, f64); LASERS],
    pub offset: [(f64, f64); LASERS],
}

impl Head {
    /// Origin and unit direction in the world of laser `l` of a firing.
    pub fn ray(&self, a: &Aim, l: usize) -> ([f64; 3], [f64; 3]) {
        let u = l as f64 / LASERS as f64;
        let origin = core::array::from_fn(|k| a.start[k] + (a.end[k] - a.start[k]) * u);
        // Azimuth of this laser (clockwise from x, as the sensor counts).
        let (s0, c0) = a.azimuth;
        let (so, co) = self.offset[l];
        let (sa, ca) = (s0 * co + c0 * so, c0 * co - s0 * so);
        let (ce, se) = self.elevation[l];
        (origin, quat::mat_mul(&a.rotation, [ce * ca, -ce * sa, se]))
    }
}

/// Firings a thread claims at a time (~250 rays): small enough that the
/// two threads end together, large enough that claiming costs nothing
/// next to casting.
const CHUNK_FIRINGS: usize = 8;

/// One chunk's firings and what their lasers met.
#[derive(Default)]
struct Chunk {
    aims: Vec<Aim>,
    returns: Vec<[RayReturn; LASERS]>,
}

/// The batch both threads work on.
struct Batch {
    world: Arc<LidarWorld>,
    head: Head,
    chunks: Vec<Mutex<Chunk>>,
    /// Chunks of the current batch ready to claim.
    published: AtomicUsize,
    /// The next chunk to claim.
    next: AtomicUsize,
    /// Range limit of the current batch, as f64 bits.
    max_m: AtomicU64,
}

impl Batch {
    /// The next published chunk nobody has claimed, claimed.
    fn claim(&self) -> Option<usize> {
        let mut i = self.next.load(Ordering::Acquire);
        loop {
            if i >= self.published.load(Ordering::Acquire) {
                return None;
            }
            match self
                .next
                .compare_exchange(i, i + 1, Ordering::AcqRel, Ordering::Acquire)
            {
                Ok(_) => return Some(i),
                Err(now) => i = now,
            }
        }
    }

    /// Claim, aim and cast published chunks until none is left.
    fn work(&self) {
        let max_m = f64::from_bits(self.max_m.load(Ordering::Acquire));
        while let Some(i) = self.claim() {
            let Some(chunk) = self.chunks.get(i) else {
                return;
            };
            let mut c = chunk.lock().unwrap_or_else(PoisonError::into_inner);
            let Chunk { aims, returns } = &mut *c;
            returns.clear();
            for a in aims.iter() {
                let mut out = [None; LASERS];
                for (l, o) in out.iter_mut().enumerate() {
                    if a.live & (1 << l) != 0 {
                        let (origin, dir) = self.head.ray(a, l);
                        *o = self.world.cast(origin, dir, max_m);
                    }
                }
                returns.push(out);
            }
        }
    }
}

/// What the helper is told.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Signal {
    /// More chunks are published.
    More,
    /// The batch is complete: say when your last chunk is cast.
    Seal,
}

struct Helper {
    go: SyncSender<Signal>,
    done: Receiver<()>,
    thread: Option<JoinHandle<()>>,
}

pub struct RayCaster {
    batch: Arc<Batch>,
    helper: Option<Helper>,
    /// A batch has been published and not collected.
    in_flight: bool,
    /// The helper was told of the current batch.
    told: bool,
}

impl RayCaster {
    /// A caster for batches of up to `capacity` firings of `head`, with a
    /// helper thread when `threads` is 2 or more (and the thread can be
    /// started).
    pub fn new(world: Arc<LidarWorld>, head: Head, capacity: usize, threads: usize) -> Self {
        let chunks = capacity.div_ceil(CHUNK_FIRINGS).max(1);
        let batch = Arc::new(Batch {
            world,
            head,
            chunks: (0..chunks)
                .map(|_| {
                    Mutex::new(Chunk {
                        aims: Vec::with_capacity(CHUNK_FIRINGS),
                        returns: Vec::with_capacity(CHUNK_FIRINGS),
                    })
                })
                .collect(),
            published: AtomicUsize::new(0),
            next: AtomicUsize::new(0),
            max_m: AtomicU64::new(0),
        });
        let helper = (threads >= 2)
            .then(|| Self::start_helper(batch.clone()))
            .flatten();
        RayCaster {
            batch,
            helper,
            in_flight: false,
            told: false,
        }
    }

    fn start_helper(batch: Arc<Batch>) -> Option<Helper> {
        // Room for every chunk's signal and the seal of a batch.
        let (go, inbox) = sync_channel::<Signal>(batch.chunks.len() + 1);
        let (outbox, done) = sync_channel::<()>(1);
        let thread = std::thread::Builder::new()
            .name("speleo-lidar".into())
            .spawn(move || {
                spare_time_only();
                while let Ok(signal) = inbox.recv() {
                    batch.work();
                    if signal == Signal::Seal && outbox.send(()).is_err() {
                        break;
                    }
                }
            })
            .ok()?;
        Some(Helper {
            go,
            done,
            thread: Some(thread),
        })
    }

    /// Whether a helper thread casts a share of each batch.
    pub fn shared(&self) -> bool {
        self.helper.is_some()
    }

    /// Firings a batch can hold.
    pub fn capacity(&self) -> usize {
        self.batch.chunks.len() * CHUNK_FIRINGS
    }

    /// Publish the chunks of `aims` (every firing of the current batch so
    /// far, in order; at most `capacity`, the rest are not cast) that are
    /// full, and with `whole` the last one too: no firing may be added to
    /// the batch after that. Rays are cast within `max_m` (the first
    /// publish of a batch sets it). The helper starts on them at once.
    pub fn publish(&mut self, aims: &[Aim], max_m: f64, whole: bool) {
        let aims = &aims[..aims.len().min(self.capacity())];
        let b = &self.batch;
        if !self.in_flight {
            b.max_m.store(max_m.to_bits(), Ordering::Release);
            b.next.store(0, Ordering::Release);
            b.published.store(0, Ordering::Release);
            self.in_flight = true;
            self.told = false;
        }
        let ready = if whole {
            aims.len().div_ceil(CHUNK_FIRINGS)
        } else {
            aims.len() / CHUNK_FIRINGS
        };
        let from = b.published.load(Ordering::Acquire);
        if ready <= from {
            return;
        }
        for c in from..ready {
            let part = &aims[c * CHUNK_FIRINGS..((c + 1) * CHUNK_FIRINGS).min(aims.len())];
            let mut chunk = b.chunks[c].lock().unwrap_or_else(PoisonError::into_inner);
            chunk.aims.clear();
            chunk.aims.extend_from_slice(part);
            chunk.returns.clear();
        }
        b.published.store(ready, Ordering::Release);
        if let Some(h) = &self.helper {
            if h.go.send(Signal::More).is_ok() {
                self.told = true;
            } else {
                // The helper is gone: cast everything here from now on.
                self.helper = None;
            }
        }
    }

    /// Finish the published batch and hand each firing's returns (indexed
    /// by laser; none for a laser that did not fire) to `each`, in order.
    /// Without a published batch nothing is handed over.
    pub fn collect(&mut self, mut each: impl FnMut(usize, &[RayReturn; LASERS])) {
        if !self.in_flight {
            return;
        }
        self.in_flight = false;
        let told = std::mem::take(&mut self.told);
        let sealed = told
            && self
                .helper
                .as_ref()
                .is_some_and(|h| h.go.send(Signal::Seal).is_ok());
        self.batch.work();
        let finished = sealed && self.helper.as_ref().is_some_and(|h| h.done.recv().is_ok());
        if told && !finished {
            // The helper is gone, perhaps mid-chunk: cast everything here.
            self.helper = None;
            self.batch.next.store(0, Ordering::Release);
            self.batch.work();
        }
        let count = self.batch.published.load(Ordering::Acquire);
        let mut k = 0;
        for chunk in &self.batch.chunks[..count] {
            let c = chunk.lock().unwrap_or_else(PoisonError::into_inner);
            for r in &c.returns {
                each(k, r);
                k += 1;
            }
        }
    }
}

/// Run the calling thread only on time nothing else wants: the rover's
/// software (the frame's thread, the internal simulator's worker) must
/// not wait for the simulated sensor, and when the helper gets no core
/// the frame's thread casts what is left. Where the scheduler refuses,
/// the thread runs as it is.
fn spare_time_only() {
    #[cfg(target_os = "linux")]
    {
        let param = libc::sched_param { sched_priority: 0 };
        // SAFETY: plain syscalls on the calling thread with valid arguments.
        if unsafe { libc::sched_setscheduler(0, libc::SCHED_IDLE, &param) } != 0 {
            // SAFETY: as above; on Linux the nice value is the thread's own.
            unsafe { libc::setpriority(libc::PRIO_PROCESS, 0, 19) };
        }
    }
}

impl Drop for Helper {
    fn drop(&mut self) {
        // Closing the channel ends the helper's loop.
        let (go, _) = sync_channel(1);
        drop(std::mem::replace(&mut self.go, go));
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::World;

    /// Firings from the tube's start, the head turning 0.63 deg a firing
    /// and pitched down a little, every laser live but one in seven.
    fn firings(n: usize) -> (World, Head, Vec<Aim>) {
        let w = World::build("lava-tube", 1).expect("tube");
        let o = [w.start[0], w.start[1], w.start[2] + 0.7];
        let head = Head {
            elevation: core::array::from_fn(|l| {
                let e = (-30.67f64 + 4.0 / 3.0 * l as f64).to_radians();
                (e.cos(), e.sin())
            }),
            offset: [(0.0, 1.0); LASERS],
        };
        let aims = (0..n)
            .map(|i| {
                let a = i as f64 * 0.011;
                Aim {
                    live: !(1u32 << (i % 7)),
                    start: o,
                    end: [o[0] + 0.001, o[1], o[2]],
                    rotation: quat::matrix(&quat::from_ypr(0.0, 0.1, 0.0)),
                    azimuth: (a.sin(), a.cos()),
                }
            })
            .collect();
        (w, head, aims)
    }

    fn all(c: &mut RayCaster) -> Vec<[RayReturn; LASERS]> {
        let mut out = Vec::new();
        c.collect(|k, r| {
            assert_eq!(k, out.len());
            out.push(*r);
        });
        out
    }

    #[test]
    fn two_threads_return_what_one_returns() {
        let (w, head, aims) = firings(100);
        let lw = Arc::new(LidarWorld::new(&w.mesh).expect("mesh"));
        let mut one = RayCaster::new(lw.clone(), head, 100, 1);
        let mut two = RayCaster::new(lw, head, 100, 2);
        assert!(!one.shared());
        assert!(two.shared());
        one.publish(&aims, 70.0, true);
        let a = all(&mut one);
        // Twice: the helper goes back to waiting between batches.
        for _ in 0..2 {
            two.publish(&aims, 70.0, true);
            assert_eq!(a, all(&mut two));
        }
        let hits = a.iter().flatten().filter(|r| r.is_some()).count();
        assert!(hits > 2500, "{hits} of 3,200 rays hit");
        // A laser that does not fire returns nothing.
        assert!(a[3][3].is_none());
        // Each ray is the one the head aims.
        let (origin, dir) = head.ray(&aims[5], 9);
        assert_eq!(a[5][9], lw_cast(&w, origin, dir));
    }

    fn lw_cast(w: &World, origin: [f64; 3], dir: [f64; 3]) -> RayReturn {
        LidarWorld::new(&w.mesh)
            .expect("mesh")
            .cast(origin, dir, 70.0)
    }

    #[test]
    fn a_published_batch_is_collected_whole_after_other_work() {
        let (w, head, aims) = firings(200);
        let lw = Arc::new(LidarWorld::new(&w.mesh).expect("mesh"));
        let mut one = RayCaster::new(lw.clone(), head, 200, 1);
        one.publish(&aims, 70.0, true);
        let a = all(&mut one);
        let mut two = RayCaster::new(lw.clone(), head, 200, 2);
        for n in [200, 10, 0] {
            two.publish(&aims[..n], 70.0, true);
            // The calling thread is free meanwhile.
            std::hint::black_box((0..10_000).sum::<u64>());
            assert_eq!(&a[..n], &all(&mut two)[..], "{n} firings");
        }
        // Published a few firings at a time, as the physics steps: the
        // helper starts on each full chunk, the last partial one goes with
        // the batch's end.
        for n in [200, 13] {
            for k in (0..n).step_by(3) {
                two.publish(&aims[..k], 70.0, false);
            }
            two.publish(&aims[..n], 70.0, true);
            assert_eq!(&a[..n], &all(&mut two)[..], "{n} firings in steps");
        }
        // Nothing published, nothing handed over.
        assert!(all(&mut two).is_empty());
        // Firings past the capacity are not cast.
        let mut small = RayCaster::new(lw, head, 16, 2);
        small.publish(&aims, 70.0, true);
        assert_eq!(&a[..small.capacity()], &all(&mut small)[..]);
    }
}

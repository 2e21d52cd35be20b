//! Casts batches of the LiDAR twin's rays, on a helper thread while the
//! rover's software runs and on the calling thread when it comes back.
//!
//! The rays of a batch are independent, so which thread casts which ray
//! changes nothing in the result: the packets are the same bytes with one
//! thread or two. Casting is most of what the simulated world costs (the
//! HDL-32E's ~580,000 rays a simulated second), and on the rover that work
//! is the sensor's own, not the computer's, so the simulation spends the
//! second core on it.
//!
//! A batch is cut into chunks that either thread claims in turn: `submit`
//! hands the batch to the helper and returns at once, `collect` casts the
//! chunks nobody has claimed yet, waits for the helper's last one and hands
//! the returns over. Between the two the calling thread is free for other
//! work. The helper thread lives as long as the caster; batches, chunks
//! and signals are made at start-up, so nothing allocates per batch.

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;

use super::lidar::LidarWorld;
use crate::world::Surface;

/// A ray to cast: origin and unit direction in the world.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct QueuedRay {
    pub origin: [f64; 3],
    pub dir: [f64; 3],
}

/// What a ray met: distance, cosine of the incidence angle and surface.
pub type RayReturn = Option<(f64, f64, Surface)>;

/// Rays a thread claims at a time: small enough that the two threads end
/// together, large enough that claiming costs nothing next to casting.
const CHUNK_RAYS: usize = 256;

/// One chunk's rays and what they met.
#[derive(Default)]
struct Chunk {
    rays: Vec<QueuedRay>,
    returns: Vec<RayReturn>,
}

/// The batch both threads work on.
struct Batch {
    world: Arc<LidarWorld>,
    chunks: Vec<Mutex<Chunk>>,
    /// Chunks in the current batch.
    count: AtomicUsize,
    /// The next chunk to claim.
    next: AtomicUsize,
    /// Range limit of the current batch, as f64 bits.
    max_m: AtomicU64,
}

impl Batch {
    /// Claim and cast chunks until none is left.
    fn work(&self) {
        let count = self.count.load(Ordering::Acquire);
        let max_m = f64::from_bits(self.max_m.load(Ordering::Acquire));
        loop {
            let i = self.next.fetch_add(1, Ordering::AcqRel);
            let Some(chunk) = self.chunks.get(i).filter(|_| i < count) else {
                return;
            };
            let mut c = chunk.lock().unwrap_or_else(PoisonError::into_inner);
            let Chunk { rays, returns } = &mut *c;
            returns.clear();
            returns.extend(rays.iter().map(|r| self.world.cast(r.origin, r.dir, max_m)));
        }
    }
}

struct Helper {
    go: SyncSender<()>,
    done: Receiver<()>,
    thread: Option<JoinHandle<()>>,
}

pub struct RayCaster {
    batch: Arc<Batch>,
    helper: Option<Helper>,
    /// A batch has been submitted and not collected.
    in_flight: bool,
    /// Rays in the submitted batch.
    rays: usize,
}

impl RayCaster {
    /// A caster for batches of up to `capacity` rays, with a helper thread
    /// when `threads` is 2 or more (and the thread can be started).
    pub fn new(world: Arc<LidarWorld>, capacity: usize, threads: usize) -> Self {
        let chunks = capacity.div_ceil(CHUNK_RAYS).max(1);
        let batch = Arc::new(Batch {
            world,
            chunks: (0..chunks)
                .map(|_| {
                    Mutex::new(Chunk {
                        rays: Vec::with_capacity(CHUNK_RAYS),
                        returns: Vec::with_capacity(CHUNK_RAYS),
                    })
                })
                .collect(),
            count: AtomicUsize::new(0),
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
            rays: 0,
        }
    }

    fn start_helper(batch: Arc<Batch>) -> Option<Helper> {
        let (go, inbox) = sync_channel::<()>(1);
        let (outbox, done) = sync_channel::<()>(1);
        let thread = std::thread::Builder::new()
            .name("speleo-lidar".into())
            .spawn(move || {
                while inbox.recv().is_ok() {
                    batch.work();
                    if outbox.send(()).is_err() {
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

    /// Rays a batch can hold.
    pub fn capacity(&self) -> usize {
        self.batch.chunks.len() * CHUNK_RAYS
    }

    /// Start casting `rays` (at most `capacity`; the rest are not cast)
    /// within `max_m`; `collect` hands the returns over. A batch still in
    /// flight is collected and dropped first.
    pub fn submit(&mut self, rays: &[QueuedRay], max_m: f64) {
        if self.in_flight {
            self.collect(&mut []);
        }
        let rays = &rays[..rays.len().min(self.capacity())];
        for (chunk, part) in self.batch.chunks.iter().zip(rays.chunks(CHUNK_RAYS)) {
            let mut c = chunk.lock().unwrap_or_else(PoisonError::into_inner);
            c.rays.clear();
            c.rays.extend_from_slice(part);
        }
        let b = &self.batch;
        b.max_m.store(max_m.to_bits(), Ordering::Release);
        b.next.store(0, Ordering::Release);
        b.count
            .store(rays.len().div_ceil(CHUNK_RAYS), Ordering::Release);
        self.rays = rays.len();
        self.in_flight = true;
        // Small batches are not worth waking the helper for.
        if rays.len() >= 2 * CHUNK_RAYS {
            if let Some(h) = &self.helper {
                if h.go.send(()).is_err() {
                    // The helper is gone: cast everything here from now on.
                    self.helper = None;
                }
            }
        }
    }

    /// Finish the submitted batch and copy its returns into `returns` (as
    /// many as both hold). Without a submitted batch nothing is copied.
    pub fn collect(&mut self, returns: &mut [RayReturn]) {
        if !self.in_flight {
            return;
        }
        self.in_flight = false;
        self.batch.work();
        if self.rays >= 2 * CHUNK_RAYS {
            if let Some(h) = &self.helper {
                if h.done.recv().is_err() {
                    // The helper died mid-batch: cast its chunks again here.
                    self.helper = None;
                    self.batch.next.store(0, Ordering::Release);
                    self.batch.work();
                }
            }
        }
        let chunks = self.batch.chunks.iter();
        let n = returns.len().min(self.rays);
        for (chunk, out) in chunks.zip(returns[..n].chunks_mut(CHUNK_RAYS)) {
            let c = chunk.lock().unwrap_or_else(PoisonError::into_inner);
            out.copy_from_slice(&c.returns[..out.len()]);
        }
    }

    /// Cast every ray of `rays` within `max_m` into `returns` (same length).
    pub fn cast(&mut self, rays: &[QueuedRay], returns: &mut [RayReturn], max_m: f64) {
        let n = rays.len().min(returns.len());
        self.submit(&rays[..n], max_m);
        self.collect(&mut returns[..n]);
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

    #[test]
    fn two_threads_return_what_one_returns() {
        let w = World::build("lava-tube", 1).expect("tube");
        let lw = Arc::new(LidarWorld::new(&w.mesh).expect("mesh"));
        let o = [w.start[0], w.start[1], w.start[2] + 0.7];
        let rays: Vec<QueuedRay> = (0..1000)
            .map(|i| {
                let a = i as f64 * 0.0063;
                let e = (i % 32) as f64 * 0.02 - 0.5;
                QueuedRay {
                    origin: o,
                    dir: [e.cos() * a.cos(), e.cos() * a.sin(), e.sin()],
                }
            })
            .collect();
        let mut one = RayCaster::new(lw.clone(), 1000, 1);
        let mut two = RayCaster::new(lw, 1000, 2);
        assert!(!one.shared());
        assert!(two.shared());
        let (mut a, mut b) = (vec![None; 1000], vec![None; 1000]);
        one.cast(&rays, &mut a, 70.0);
        // Twice: the share comes home and goes out again.
        two.cast(&rays, &mut b, 70.0);
        assert_eq!(a, b);
        b.fill(None);
        two.cast(&rays, &mut b, 70.0);
        assert_eq!(a, b);
        assert!(a.iter().filter(|r| r.is_some()).count() > 900);
    }

    #[test]
    fn a_submitted_batch_is_collected_whole_after_other_work() {
        let w = World::build("lava-tube", 1).expect("tube");
        let lw = Arc::new(LidarWorld::new(&w.mesh).expect("mesh"));
        let o = [w.start[0], w.start[1], w.start[2] + 0.7];
        let rays: Vec<QueuedRay> = (0..3000)
            .map(|i| {
                let a = i as f64 * 0.0021;
                QueuedRay {
                    origin: o,
                    dir: [a.cos() * 0.9, a.sin() * 0.9, -0.43589],
                }
            })
            .collect();
        let mut one = RayCaster::new(lw.clone(), 3000, 1);
        let mut two = RayCaster::new(lw, 3000, 2);
        let mut a = vec![None; 3000];
        one.cast(&rays, &mut a, 70.0);
        for n in [3000, 100, 0] {
            two.submit(&rays[..n], 70.0);
            // The calling thread is free meanwhile.
            std::hint::black_box((0..10_000).sum::<u64>());
            let mut b = vec![None; 3000];
            two.collect(&mut b);
            assert_eq!(&a[..n], &b[..n], "{n} rays");
            assert!(b[n..].iter().all(Option::is_none), "{n} rays");
        }
        // Nothing submitted, nothing copied.
        let mut c = vec![None; 10];
        two.collect(&mut c);
        assert!(c.iter().all(Option::is_none));
        // Rays past the capacity are not cast.
        let mut small = RayCaster::new(Arc::new(LidarWorld::new(&w.mesh).expect("mesh")), 256, 2);
        let mut d = vec![None; 3000];
        small.cast(&rays, &mut d, 70.0);
        assert_eq!(&a[..small.capacity()], &d[..small.capacity()]);
        assert!(d[small.capacity()..].iter().all(Option::is_none));
    }
}

//! Casts a batch of the LiDAR twin's rays, half of it on a helper thread.
//!
//! The rays of a batch are independent, so which thread casts which ray
//! changes nothing in the result: the packets are the same bytes with one
//! thread or two. Casting is most of what the simulated world costs (the
//! HDL-32E's ~580,000 rays a simulated second), and on the rover that work
//! is the sensor's own, not the computer's, so the simulation spends the
//! second core on it. The helper thread lives as long as the caster; a
//! batch travels to it and back through bounded channels without
//! allocating.

use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::Arc;
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

/// Batches smaller than this are cast on the calling thread: the hand-over
/// would cost more than it saves.
const MIN_SHARED_RAYS: usize = 64;

/// The half of a batch the helper casts.
struct Share {
    rays: Vec<QueuedRay>,
    returns: Vec<RayReturn>,
    max_m: f64,
}

struct Helper {
    to: SyncSender<Share>,
    back: Receiver<Share>,
    /// The share, while it is home.
    share: Option<Share>,
    thread: Option<JoinHandle<()>>,
}

pub struct RayCaster {
    world: Arc<LidarWorld>,
    helper: Option<Helper>,
}

fn cast_all(world: &LidarWorld, rays: &[QueuedRay], returns: &mut [RayReturn], max_m: f64) {
    for (r, out) in rays.iter().zip(returns.iter_mut()) {
        *out = world.cast(r.origin, r.dir, max_m);
    }
}

impl RayCaster {
    /// A caster for batches of up to `capacity` rays, with a helper thread
    /// when `threads` is 2 or more (and the thread can be started).
    pub fn new(world: Arc<LidarWorld>, capacity: usize, threads: usize) -> Self {
        let helper = (threads >= 2)
            .then(|| Self::start_helper(world.clone(), capacity))
            .flatten();
        RayCaster { world, helper }
    }

    fn start_helper(world: Arc<LidarWorld>, capacity: usize) -> Option<Helper> {
        let (to, inbox) = sync_channel::<Share>(1);
        let (outbox, back) = sync_channel::<Share>(1);
        let thread = std::thread::Builder::new()
            .name("speleo-lidar".into())
            .spawn(move || {
                while let Ok(mut s) = inbox.recv() {
                    let n = s.rays.len();
                    s.returns.clear();
                    s.returns.resize(n, None);
                    cast_all(&world, &s.rays, &mut s.returns, s.max_m);
                    if outbox.send(s).is_err() {
                        break;
                    }
                }
            })
            .ok()?;
        let half = capacity / 2 + 1;
        Some(Helper {
            to,
            back,
            share: Some(Share {
                rays: Vec::with_capacity(half),
                returns: Vec::with_capacity(half),
                max_m: 0.0,
            }),
            thread: Some(thread),
        })
    }

    /// Whether a helper thread casts half of each batch.
    pub fn shared(&self) -> bool {
        self.helper.is_some()
    }

    /// Cast every ray of `rays` within `max_m` into `returns` (same length).
    pub fn cast(&mut self, rays: &[QueuedRay], returns: &mut [RayReturn], max_m: f64) {
        let n = rays.len().min(returns.len());
        let (rays, returns) = (&rays[..n], &mut returns[..n]);
        let helper = match &mut self.helper {
            Some(h) if n >= MIN_SHARED_RAYS => h,
            _ => return cast_all(&self.world, rays, returns, max_m),
        };
        let Some(mut share) = helper.share.take() else {
            return cast_all(&self.world, rays, returns, max_m);
        };
        let mid = n / 2;
        share.rays.clear();
        share.rays.extend_from_slice(&rays[mid..]);
        share.max_m = max_m;
        if helper.to.send(share).is_err() {
            // The helper is gone: cast everything here from now on.
            self.helper = None;
            return cast_all(&self.world, rays, returns, max_m);
        }
        cast_all(&self.world, &rays[..mid], &mut returns[..mid], max_m);
        match helper.back.recv() {
            Ok(share) => {
                returns[mid..].copy_from_slice(&share.returns);
                helper.share = Some(share);
            }
            Err(_) => {
                self.helper = None;
                cast_all(&self.world, &rays[mid..], &mut returns[mid..], max_m);
            }
        }
    }
}

impl Drop for Helper {
    fn drop(&mut self) {
        // Closing the channel ends the helper's loop.
        let (to, _) = sync_channel(1);
        drop(std::mem::replace(&mut self.to, to));
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
}

//! A coprocessor: a worker thread, on a core of its own, that does one
//! fixed batch of an anytime task's work between two of its runs.
//!
//! The task lends its job (a boxed state machine) with a number of work
//! units at the end of its run in frame `n`; the worker does exactly those
//! units; the task takes the job back in its next run (frame `n + 1`),
//! waiting if the worker is not done. The work done and the frame at which
//! its results are seen depend only on the units, never on how fast the
//! worker was, so outputs stay bit-identical on any machine and at any
//! speed; only the time budget of a batch (a frame on the worker's core)
//! is at stake, and it is measured ([`Batch::elapsed_ns`], and on the
//! worker thread's CPU clock [`Batch::cpu_ns`], which leaves out the time
//! other threads on its core took).
//!
//! Between frames the application calls [`FrameSync::wait_idle`] (on a
//! virtual clock the frames come back to back, and this is where a real
//! rover's executive would sleep until the next frame), so that the task's
//! own run never waits and its time stays its own.
//!
//! Nothing allocates after [`Coprocessor::spawn`]: the job moves as a box,
//! and the lock and condition variable are futexes. The worker's own
//! allocations are counted on its thread in the lending task's slot and
//! handed back with the batch, so the task can be charged for them
//! ([`crate::accounting::charge`]).

use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;

use crate::{accounting, realtime};

/// What one batch cost on the worker.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Batch {
    /// Wall time of the batch, ns.
    pub elapsed_ns: u64,
    /// The worker thread's CPU time in the batch, ns
    /// (`CLOCK_THREAD_CPUTIME_ID`).
    pub cpu_ns: u64,
    /// Heap allocations made, and bytes requested.
    pub allocations: u64,
    pub bytes: u64,
}

#[derive(Default)]
struct Control {
    /// A batch was lent and not yet begun.
    pending: bool,
    /// The worker is doing a batch.
    busy: bool,
    quit: bool,
    units: u32,
    last: Batch,
}

struct Shared<T> {
    control: Mutex<Control>,
    changed: Condvar,
    job: Mutex<Option<Box<T>>>,
}

fn lock<X>(m: &Mutex<X>) -> MutexGuard<'_, X> {
    // Nothing panics while holding these locks; a poisoned one still holds
    // consistent data.
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Waits for a coprocessor to be idle; held by the application's frame
/// loop. Type-erased, so one loop can hold the handles of any jobs.
#[derive(Clone)]
pub struct FrameSync {
    shared: Arc<dyn Idle + Send + Sync>,
}

trait Idle {
    fn wait_idle(&self);
}

impl<T: Send> Idle for Shared<T> {
    fn wait_idle(&self) {
        let mut c = lock(&self.control);
        while c.pending || c.busy {
            c = self.changed.wait(c).unwrap_or_else(|e| e.into_inner());
        }
    }
}

impl FrameSync {
    /// Return once the batch lent (if any) is done.
    pub fn wait_idle(&self) {
        self.shared.wait_idle();
    }
}

/// See the module documentation.
pub struct Coprocessor<T: Send + 'static> {
    shared: Arc<Shared<T>>,
    thread: Option<JoinHandle<()>>,
    lent: bool,
}

impl<T: Send + 'static> Coprocessor<T> {
    /// Start the worker thread `name`; it counts its allocations in
    /// accounting slot `slot` and does a batch by calling `work(job, units)`.
    pub fn spawn(name: &str, slot: u16, work: fn(&mut T, u32)) -> std::io::Result<Self> {
        let shared = Arc::new(Shared {
            control: Mutex::new(Control::default()),
            changed: Condvar::new(),
            job: Mutex::new(None),
        });
        let s = Arc::clone(&shared);
        let thread = std::thread::Builder::new()
            .name(name.to_string())
            .spawn(move || serve(&s, slot, work))?;
        Ok(Coprocessor {
            shared,
            thread: Some(thread),
            lent: false,
        })
    }

    /// A handle for the frame loop's [`FrameSync::wait_idle`].
    pub fn sync(&self) -> FrameSync {
        FrameSync {
            shared: Arc::clone(&self.shared) as Arc<dyn Idle + Send + Sync>,
        }
    }

    /// Whether a job is out on the worker.
    pub fn is_lent(&self) -> bool {
        self.lent
    }

    /// Hand `job` over for `units` of work. A job already out is not
    /// replaced: `job` is given back.
    pub fn lend(&mut self, job: Box<T>, units: u32) -> Result<(), Box<T>> {
        if self.lent {
            return Err(job);
        }
        *lock(&self.shared.job) = Some(job);
        let mut c = lock(&self.shared.control);
        c.pending = true;
        c.units = units;
        self.lent = true;
        self.shared.changed.notify_all();
        Ok(())
    }

    /// The job back once its batch is done (waiting for it), with what the
    /// batch cost; `None` when nothing is out.
    pub fn join(&mut self) -> Option<(Box<T>, Batch)> {
        if !self.lent {
            return None;
        }
        self.shared.wait_idle();
        self.lent = false;
        let batch = lock(&self.shared.control).last;
        lock(&self.shared.job).take().map(|j| (j, batch))
    }
}

impl<T: Send + 'static> Drop for Coprocessor<T> {
    fn drop(&mut self) {
        lock(&self.shared.control).quit = true;
        self.shared.changed.notify_all();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The worker's loop: wait for a batch, do it, report it.
fn serve<T: Send>(s: &Shared<T>, slot: u16, work: fn(&mut T, u32)) {
    accounting::set_slot(slot);
    loop {
        let units = {
            let mut c = lock(&s.control);
            while !c.pending && !c.quit {
                c = s.changed.wait(c).unwrap_or_else(|e| e.into_inner());
            }
            if c.quit {
                return;
            }
            c.pending = false;
            c.busy = true;
            c.units
        };
        let n0 = accounting::allocations(slot as usize);
        let b0 = accounting::bytes(slot as usize);
        let t0 = std::time::Instant::now();
        let c0 = realtime::thread_cpu_ns();
        if let Some(job) = lock(&s.job).as_deref_mut() {
            work(job, units);
        }
        let batch = Batch {
            elapsed_ns: t0.elapsed().as_nanos() as u64,
            cpu_ns: realtime::thread_cpu_ns().saturating_sub(c0),
            allocations: accounting::allocations(slot as usize) - n0,
            bytes: accounting::bytes(slot as usize) - b0,
        };
        let mut c = lock(&s.control);
        c.busy = false;
        c.last = batch;
        s.changed.notify_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A job whose result depends on the order of its batches only.
    struct Sum {
        acc: u64,
        seen: Vec<u32>,
    }

    fn add(s: &mut Sum, units: u32) {
        for k in 0..units as u64 {
            s.acc = s.acc.wrapping_mul(31).wrapping_add(k);
        }
        s.seen.push(units);
    }

    #[test]
    fn batches_run_on_the_worker_in_the_order_lent_and_give_the_job_back() {
        let mut cp = Coprocessor::spawn("test-worker", 3, add).expect("thread");
        let mut job = Box::new(Sum {
            acc: 1,
            seen: Vec::with_capacity(8),
        });
        let mut local = Sum {
            acc: 1,
            seen: Vec::new(),
        };
        for units in [5, 0, 17, 3] {
            assert!(cp.lend(job, units).is_ok());
            assert!(cp.is_lent());
            cp.sync().wait_idle();
            let (j, batch) = cp.join().expect("lent");
            assert!(batch.elapsed_ns < 10_000_000_000);
            assert!(batch.cpu_ns <= batch.elapsed_ns + 1_000_000);
            job = j;
            add(&mut local, units);
        }
        assert!(!cp.is_lent());
        assert!(cp.join().is_none());
        assert_eq!(job.acc, local.acc);
        assert_eq!(job.seen, [5, 0, 17, 3]);
    }

    #[test]
    fn a_second_lend_while_one_is_out_gives_the_job_back() {
        let mut cp = Coprocessor::spawn("test-worker", 3, add).expect("thread");
        let job = || {
            Box::new(Sum {
                acc: 0,
                seen: Vec::with_capacity(4),
            })
        };
        assert!(cp.lend(job(), 1).is_ok());
        let refused = cp.lend(job(), 2).expect_err("one job at a time");
        assert!(refused.seen.is_empty());
        let (j, _) = cp.join().expect("lent");
        assert_eq!(j.seen, [1]);
    }
}

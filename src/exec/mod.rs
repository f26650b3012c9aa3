//! How the CPU's threads run: the same per-item function, serially or with
//! rayon. (The device a search's layers run on, CPU or GPU, is another
//! choice: `--backend` on the CLI, `matchGpu` in JavaScript.)
//!
//! Every parallel step in the pipeline goes through [`Threads`], and every one
//! of them produces results in input order or combines them with an
//! order-independent operation (bitwise OR), so serial and parallel runs
//! give identical results; a test at the top level checks it on whole
//! searches.

use std::ops::{ControlFlow, Range};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, Ordering};

/// The value in `cell`, made by `make` if it is empty. Made outside the
/// cell's lock: a thread waiting on the lock inside a parallel loop could
/// be handed that loop's own work and so wait on itself. Two threads may
/// both make it; one value is kept.
pub fn made_once<T>(cell: &OnceLock<T>, make: impl FnOnce() -> T) -> &T {
    if let Some(value) = cell.get() {
        return value;
    }
    let made = make();
    cell.get_or_init(|| made)
}

/// How data-parallel work runs on the CPU's threads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Threads {
    /// One thread, in order.
    Serial,
    /// rayon's current thread pool (serial when the `parallel` feature is off).
    #[default]
    Parallel,
}

impl Threads {
    /// Whether work really runs on several threads.
    pub fn is_parallel(self) -> bool {
        cfg!(feature = "parallel") && self == Threads::Parallel
    }

    /// How many threads the work runs on.
    pub fn count(self) -> usize {
        #[cfg(feature = "parallel")]
        if self.is_parallel() {
            return rayon::current_num_threads();
        }
        1
    }

    /// Calls `f` on consecutive sub-ranges of `0..len` of about `grain` items.
    pub fn for_each_range<F>(self, len: usize, grain: usize, f: F)
    where
        F: Fn(Range<usize>) + Sync + Send,
    {
        let grain = grain.max(1);
        let chunks = len.div_ceil(grain);
        let range = |c: usize| c * grain..((c + 1) * grain).min(len);
        #[cfg(feature = "parallel")]
        if self.is_parallel() {
            use rayon::prelude::*;
            (0..chunks).into_par_iter().for_each(|c| f(range(c)));
            return;
        }
        (0..chunks).for_each(|c| f(range(c)));
    }

    /// `f(i)` for every `i` in `0..len`, keeping the `Some` results in order.
    pub fn filter_map<R, F>(self, len: usize, f: F) -> Vec<R>
    where
        R: Send,
        F: Fn(usize) -> Option<R> + Sync + Send,
    {
        #[cfg(feature = "parallel")]
        if self.is_parallel() {
            use rayon::prelude::*;
            return (0..len)
                .into_par_iter()
                .with_min_len(64)
                .filter_map(f)
                .collect();
        }
        (0..len).filter_map(f).collect()
    }

    /// `f(item)` for every item, consuming them, keeping the `Some` results
    /// in order.
    pub fn filter_map_owned<T, R, F>(self, items: Vec<T>, f: F) -> Vec<R>
    where
        T: Send,
        R: Send,
        F: Fn(T) -> Option<R> + Sync + Send,
    {
        #[cfg(feature = "parallel")]
        if self.is_parallel() {
            use rayon::prelude::*;
            return items
                .into_par_iter()
                .with_min_len(16)
                .filter_map(f)
                .collect();
        }
        items.into_iter().filter_map(f).collect()
    }

    /// Like [`Threads::filter_map_owned`] over `items` paired with
    /// `values` in order (equal lengths).
    pub fn filter_map_zipped<T, V, R, F>(self, items: Vec<T>, values: Vec<V>, f: F) -> Vec<R>
    where
        T: Send,
        V: Send,
        R: Send,
        F: Fn(T, V) -> Option<R> + Sync + Send,
    {
        assert_eq!(items.len(), values.len(), "one value per item");
        #[cfg(feature = "parallel")]
        if self.is_parallel() {
            use rayon::prelude::*;
            return items
                .into_par_iter()
                .zip(values)
                .with_min_len(16)
                .filter_map(|(t, v)| f(t, v))
                .collect();
        }
        items
            .into_iter()
            .zip(values)
            .filter_map(|(t, v)| f(t, v))
            .collect()
    }

    /// `f(row, chunk)` for consecutive chunks of `row_len` items of `data`
    /// (the last may be shorter), writing in place.
    pub fn for_each_row<T, F>(self, data: &mut [T], row_len: usize, f: F)
    where
        T: Send,
        F: Fn(usize, &mut [T]) + Sync + Send,
    {
        let row_len = row_len.max(1);
        #[cfg(feature = "parallel")]
        if self.is_parallel() {
            use rayon::prelude::*;
            data.par_chunks_mut(row_len)
                .enumerate()
                .for_each(|(i, c)| f(i, c));
            return;
        }
        data.chunks_mut(row_len)
            .enumerate()
            .for_each(|(i, c)| f(i, c));
    }

    /// `f(i)` for every `i` in `0..len`, in order.
    pub fn map<R, F>(self, len: usize, f: F) -> Vec<R>
    where
        R: Send,
        F: Fn(usize) -> R + Sync + Send,
    {
        // Not `filter_map`: a known length lets rayon write every result in
        // place, where filtering gathers pieces and copies them again.
        #[cfg(feature = "parallel")]
        if self.is_parallel() {
            use rayon::prelude::*;
            return (0..len).into_par_iter().with_min_len(64).map(f).collect();
        }
        (0..len).map(f).collect()
    }

    /// Like [`Threads::map`] for a few expensive items (milliseconds each,
    /// such as verifying a placement): every item may go to its own thread,
    /// where `map` hands out at least 64 at a time and so runs a short list
    /// on one thread.
    pub fn map_each<R, F>(self, len: usize, f: F) -> Vec<R>
    where
        R: Send,
        F: Fn(usize) -> R + Sync + Send,
    {
        #[cfg(feature = "parallel")]
        if self.is_parallel() {
            use rayon::prelude::*;
            return (0..len).into_par_iter().map(f).collect();
        }
        (0..len).map(f).collect()
    }

    /// Like [`Threads::map_each`], but each item may tell the calling
    /// thread events as it runs, and the calling thread hands them to
    /// `listen` at once: the observer of a search is not thread-safe (a
    /// JavaScript callback), yet parts searched side by side must show
    /// their progress before all of them end. Once `listen` breaks, every
    /// later [`Teller::tell`] answers `Break`, and the items should stop.
    /// Inside a pool thread the events wait for the items' end: blocking
    /// there could starve the pool.
    pub fn map_each_told<R, E, F, L>(self, len: usize, f: F, mut listen: L) -> Vec<R>
    where
        R: Send,
        E: Send,
        F: Fn(usize, &Teller<'_, E>) -> R + Sync + Send,
        L: FnMut(E) -> ControlFlow<()>,
    {
        // Counting the pool's threads starts it first: where threads cannot
        // be spawned (plain WebAssembly), rayon makes the calling thread its
        // only worker, which runs the items in order and can tell directly.
        #[cfg(feature = "parallel")]
        if self.is_parallel() {
            let threads = rayon::current_num_threads();
            match rayon::current_thread_index() {
                None => return relayed(len, &f, &mut listen),
                Some(_) if threads > 1 => {
                    let stopped = AtomicBool::new(false);
                    let held = std::sync::Mutex::new(Vec::new());
                    let results = self.map_each(len, |i| {
                        let route = Route::Held(&held);
                        f(
                            i,
                            &Teller {
                                route,
                                stopped: &stopped,
                            },
                        )
                    });
                    for event in held.into_inner().unwrap_or_else(|e| e.into_inner()) {
                        if listen(event).is_break() {
                            break;
                        }
                    }
                    return results;
                }
                Some(_) => {}
            }
        }
        let stopped = AtomicBool::new(false);
        let teller = Teller {
            route: Route::Direct(std::cell::RefCell::new(&mut listen)),
            stopped: &stopped,
        };
        (0..len).map(|i| f(i, &teller)).collect()
    }

    /// Sorts `data`. Unstable, so the backends agree only where no two items
    /// compare equal: callers sort keys made unique (an index as the last
    /// field).
    pub fn sort_unstable<T: Ord + Send>(self, data: &mut [T]) {
        #[cfg(feature = "parallel")]
        if self.is_parallel() {
            use rayon::prelude::*;
            data.par_sort_unstable();
            return;
        }
        data.sort_unstable();
    }

    /// Sorts each run of consecutive items that `same_run` joins, in place:
    /// a second pass after a counting sort by a coarser key.
    pub fn sort_runs_unstable<T, F>(self, data: &mut [T], same_run: F)
    where
        T: Ord + Send,
        F: Fn(&T, &T) -> bool + Sync + Send,
    {
        #[cfg(feature = "parallel")]
        if self.is_parallel() {
            use rayon::prelude::*;
            data.par_chunk_by_mut(same_run)
                .for_each(|run| run.sort_unstable());
            return;
        }
        data.chunk_by_mut(same_run)
            .for_each(|run| run.sort_unstable());
    }

    /// Runs two independent jobs, at the same time where threads allow, so
    /// that a serial step of one overlaps the parallel work of the other.
    pub fn join<A, B, FA, FB>(self, a: FA, b: FB) -> (A, B)
    where
        A: Send,
        B: Send,
        FA: FnOnce() -> A + Send,
        FB: FnOnce() -> B + Send,
    {
        #[cfg(feature = "parallel")]
        if self.is_parallel() {
            return rayon::join(a, b);
        }
        (a(), b())
    }
}

/// How an item of [`Threads::map_each_told`] reaches the calling thread,
/// and whether its listener asked to stop.
pub struct Teller<'a, E> {
    route: Route<'a, E>,
    stopped: &'a AtomicBool,
}

/// The way a [`Teller`]'s events go.
enum Route<'a, E> {
    /// To the listener, on the calling thread itself.
    Direct(std::cell::RefCell<&'a mut dyn FnMut(E) -> ControlFlow<()>>),
    /// Through a channel the calling thread reads while the items run.
    #[cfg(feature = "parallel")]
    Relayed(&'a std::sync::mpsc::Sender<E>),
    /// Kept until the items end (inside a pool thread).
    #[cfg(feature = "parallel")]
    Held(&'a std::sync::Mutex<Vec<E>>),
}

impl<E> Teller<'_, E> {
    /// Hands `event` to the calling thread; `Break` once its listener
    /// asked to stop.
    pub fn tell(&self, event: E) -> ControlFlow<()> {
        let stop = match &self.route {
            Route::Direct(listen) => {
                !self.stopped.load(Ordering::Relaxed) && listen.borrow_mut()(event).is_break()
            }
            // A closed channel: the calling thread stopped listening.
            #[cfg(feature = "parallel")]
            Route::Relayed(sender) => sender.send(event).is_err(),
            #[cfg(feature = "parallel")]
            Route::Held(held) => {
                held.lock().unwrap_or_else(|e| e.into_inner()).push(event);
                false
            }
        };
        if stop {
            self.stopped.store(true, Ordering::Relaxed);
        }
        match self.stopped.load(Ordering::Relaxed) {
            true => ControlFlow::Break(()),
            false => ControlFlow::Continue(()),
        }
    }
}

/// [`Threads::map_each_told`] on rayon's pool, called from outside it: the
/// items run on the pool while this thread hands their events on.
#[cfg(feature = "parallel")]
fn relayed<R, E, F, L>(len: usize, f: &F, listen: &mut L) -> Vec<R>
where
    R: Send,
    E: Send,
    F: Fn(usize, &Teller<'_, E>) -> R + Sync + Send,
    L: FnMut(E) -> ControlFlow<()>,
{
    use rayon::prelude::*;
    let stopped = AtomicBool::new(false);
    let (sender, receiver) = std::sync::mpsc::channel::<E>();
    let results = std::sync::Mutex::new(None);
    rayon::in_place_scope(|scope| {
        let (stopped, results) = (&stopped, &results);
        // Moved in: the items' end, or a panic, drops the only sender,
        // which ends the loop below; the scope then passes a panic on.
        scope.spawn(move |_| {
            let sender = &sender;
            let mapped: Vec<R> = (0..len)
                .into_par_iter()
                .map(|i| {
                    let route = Route::Relayed(sender);
                    f(i, &Teller { route, stopped })
                })
                .collect();
            *results.lock().unwrap_or_else(|e| e.into_inner()) = Some(mapped);
        });
        for event in receiver.iter() {
            if !stopped.load(Ordering::Relaxed) && listen(event).is_break() {
                stopped.store(true, Ordering::Relaxed);
            }
        }
    });
    results
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
        .expect("every item ran")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    #[test]
    fn backends_agree() {
        let f = |i: usize| i.is_multiple_of(3).then_some(i * i);
        assert_eq!(
            Threads::Serial.filter_map(10_000, f),
            Threads::Parallel.filter_map(10_000, f)
        );
        assert_eq!(
            Threads::Serial.map_each(100, |i| i * i),
            Threads::Parallel.map_each(100, |i| i * i)
        );
        // Each item meets its own value, and the kept ones stay in order.
        let zipped = |b: Threads| {
            let items: Vec<usize> = (0..10_000).collect();
            let values: Vec<usize> = (0..10_000).map(|i| 3 * i).collect();
            b.filter_map_zipped(items, values, |i, v| i.is_multiple_of(7).then_some((i, v)))
        };
        let expected: Vec<(usize, usize)> = (0..10_000).step_by(7).map(|i| (i, 3 * i)).collect();
        assert_eq!(zipped(Threads::Serial), expected);
        assert_eq!(zipped(Threads::Parallel), expected);
        for b in [Threads::Serial, Threads::Parallel] {
            let sum = AtomicUsize::new(0);
            b.for_each_range(1000, 7, |r| {
                sum.fetch_add(r.sum::<usize>(), Ordering::Relaxed);
            });
            assert_eq!(sum.into_inner(), 999 * 1000 / 2);
            let mut keys: Vec<(u32, usize)> =
                (0..50_000).map(|i| ((i * 7919 % 1000) as u32, i)).collect();
            b.sort_unstable(&mut keys);
            assert!(keys.is_sorted());
            let mut runs: Vec<(u32, usize)> =
                (0..50_000).rev().map(|i| ((i / 5) as u32, i)).collect();
            b.sort_runs_unstable(&mut runs, |x, y| x.0 == y.0);
            assert!(runs.chunks(5).all(|r| r.is_sorted()));
            assert!(!runs.is_sorted());
        }
    }

    #[test]
    fn told_events_reach_the_caller_while_the_items_run() {
        for b in [Threads::Serial, Threads::Parallel] {
            let heard = AtomicBool::new(false);
            // Item 0 waits for its own event to be heard: were events held
            // until the items end, it would wait out its bound.
            let waited = b.map_each_told(
                4,
                |i, teller| {
                    if i != 0 {
                        return true;
                    }
                    let _ = teller.tell(i);
                    let bound = std::time::Instant::now() + std::time::Duration::from_secs(20);
                    while !heard.load(Ordering::Acquire) {
                        if std::time::Instant::now() > bound {
                            return false;
                        }
                        std::thread::yield_now();
                    }
                    true
                },
                |_| {
                    heard.store(true, Ordering::Release);
                    ControlFlow::Continue(())
                },
            );
            assert_eq!(waited, vec![true; 4], "{b:?}");
        }
    }

    #[test]
    fn a_break_from_the_listener_is_every_later_answer() {
        for b in [Threads::Serial, Threads::Parallel] {
            let heard = AtomicUsize::new(0);
            let answers = b.map_each_told(
                1,
                |_, teller| {
                    // Relayed, the break lands once the listener has run;
                    // what is told meanwhile is not heard.
                    let bound = std::time::Instant::now() + std::time::Duration::from_secs(20);
                    while teller.tell(1).is_continue() && std::time::Instant::now() < bound {
                        std::thread::yield_now();
                    }
                    [teller.tell(2), teller.tell(3)]
                },
                |_| {
                    heard.fetch_add(1, Ordering::AcqRel);
                    ControlFlow::Break(())
                },
            );
            assert_eq!(answers[0], [ControlFlow::Break(()); 2], "{b:?}");
            assert_eq!(heard.into_inner(), 1, "{b:?}");
        }
    }

    // WebAssembly without threads has no pool to build.
    #[cfg(not(target_family = "wasm"))]
    #[test]
    fn inside_the_pool_every_told_event_is_heard_at_the_end() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let mut heard = Vec::new();
        let results = pool.install(|| {
            Threads::Parallel.map_each_told(
                50,
                |i, teller| {
                    let _ = teller.tell(i);
                    i * 2
                },
                |e| {
                    heard.push(e);
                    ControlFlow::Continue(())
                },
            )
        });
        heard.sort_unstable();
        assert_eq!(heard, (0..50).collect::<Vec<_>>());
        assert_eq!(results, (0..50).map(|i| i * 2).collect::<Vec<_>>());
    }
}

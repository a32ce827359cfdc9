//! Panics in user-geometry callbacks, the git2 way: no panic unwinds into Embree; each callback
//! body runs under `catch_unwind`, and the payload is handed back to Rust code once Embree has
//! returned.
//!
//! * Ray queries (`rtcIntersect*` / `rtcOccluded*`) run their callbacks on the calling thread.
//!   A [`Scene`](super::Scene) query runs inside [`query`], which marks the thread as waiting;
//!   a callback panic is stashed in a thread-local slot, the remaining callbacks of that query
//!   are skipped (they see a miss), and [`query`] resumes the panic when Embree returns.
//! * Bounds callbacks run on Embree's build threads during `rtcCommitScene`: the panic is
//!   recorded in the geometry's [`PanicRecord`], and [`Scene::commit`](super::Scene::commit)
//!   returns it as [`EmbreeError::CallbackPanicked`](super::EmbreeError::CallbackPanicked).
//! * A query made by the caller's own Embree code (the raw and C APIs) has nobody waiting on
//!   the thread: its callback panics are recorded in the geometry's record too, and the query
//!   sees a miss.

use std::any::Any;
use std::cell::Cell;
use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

thread_local! {
    /// `2 * (queries in progress on this thread) + (a payload is pending)`: one read per
    /// callback on the hot path.
    static STATE: Cell<u32> = const { Cell::new(0) };
    /// The first callback panic of the current query on this thread.
    static PAYLOAD: Cell<Option<Box<dyn Any + Send>>> = const { Cell::new(None) };
}

const PENDING: u32 = 1;
const DEPTH: u32 = 2;

/// The panic message of a payload, if it is a string (as `panic!` makes it).
pub(crate) fn message(payload: &(dyn Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&'static str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "(a panic payload that is not a string)".to_string()
    }
}

/// What a geometry's callbacks record when they panic with no Rust caller waiting on the thread.
#[derive(Debug, Default)]
pub(crate) struct PanicRecord {
    /// The first such panic since the last [`PanicRecord::take`]: the callback and the message.
    first: Mutex<Option<(&'static str, String)>>,
    /// How many such panics there were since the record was made.
    count: AtomicU64,
}

impl PanicRecord {
    fn record(&self, callback: &'static str, payload: &(dyn Any + Send)) {
        self.count.fetch_add(1, Ordering::Relaxed);
        // A poisoned lock still holds a valid Option: keep recording into it.
        let mut first = self.first.lock().unwrap_or_else(|e| e.into_inner());
        if first.is_none() {
            *first = Some((callback, message(payload)));
        }
    }

    /// The first recorded panic (callback name, message), clearing it.
    pub(crate) fn take(&self) -> Option<(&'static str, String)> {
        self.first.lock().unwrap_or_else(|e| e.into_inner()).take()
    }

    /// How many callback panics were recorded since the geometry was made.
    pub(crate) fn count(&self) -> u64 {
        self.count.load(Ordering::Relaxed)
    }
}

/// Run the body of `callback` for a geometry with `record`: `Some(result)`, or `None` if it
/// panicked or if an earlier callback of the same query already did (then the body is skipped).
#[inline(always)]
pub(crate) fn wrap<R>(record: &PanicRecord, callback: &'static str, f: impl FnOnce() -> R) -> Option<R> {
    let state = STATE.with(Cell::get);
    if state & PENDING != 0 {
        return None;
    }
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => Some(r),
        Err(payload) => {
            if state >= DEPTH {
                // A `query` on this thread is waiting: it resumes the panic.
                PAYLOAD.with(|p| p.set(Some(payload)));
                STATE.with(|s| s.set(s.get() | PENDING));
            } else {
                record.record(callback, &*payload);
            }
            None
        }
    }
}

/// Run a ray query (`f` calls `rtcIntersect*` / `rtcOccluded*`, which cannot unwind) and resume
/// the first callback panic it stashed, if any, once Embree has returned.
#[inline(always)]
pub(crate) fn query<R>(f: impl FnOnce() -> R) -> R {
    let outer = STATE.with(|s| s.replace(s.get() + DEPTH));
    let r = f();
    // Back to the outer depth; a pending flag set during this query goes with it.
    let pending = STATE.with(|s| s.replace(outer)) & PENDING;
    if pending != 0 {
        if let Some(payload) = PAYLOAD.with(Cell::take) {
            resume_unwind(payload);
        }
    }
    r
}

/// Run a non-query callback body (bounds), recording a panic in `record`.
#[inline(always)]
pub(crate) fn record_on_panic<R>(
    record: &PanicRecord,
    callback: &'static str,
    f: impl FnOnce() -> R,
) -> Option<R> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => Some(r),
        Err(payload) => {
            record.record(callback, &*payload);
            None
        }
    }
}

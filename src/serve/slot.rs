//! A "latest state wins" mailbox between threads: one value that writers update in place and a
//! reader takes when it has changed. However many updates arrive while the reader is busy, it
//! sees one, the newest — nothing queues, so a flood of camera messages costs neither memory
//! nor latency.

use std::sync::{Condvar, Mutex, MutexGuard};
use std::time::Duration;

/// One value, a flag saying whether it changed since it was last taken, and whether the slot
/// is closed (the reader should stop).
pub struct Slot<T> {
    inner: Mutex<Inner<T>>,
    changed: Condvar,
}

struct Inner<T> {
    value: T,
    fresh: bool,
    closed: bool,
}

/// What [`Slot::wait`] found.
#[derive(Debug, PartialEq)]
pub enum Taken<T> {
    /// The value, changed since the last take.
    Fresh(T),
    /// Nothing changed within the timeout.
    Unchanged,
    /// The slot was closed.
    Closed,
}

impl<T: Clone> Slot<T> {
    pub fn new(value: T) -> Self {
        Self { inner: Mutex::new(Inner { value, fresh: false, closed: false }), changed: Condvar::new() }
    }

    fn lock(&self) -> MutexGuard<'_, Inner<T>> {
        // A writer that panicked left a whole value (updates are single assignments).
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Changes the value in place and marks it fresh; wakes the reader.
    pub fn update<R>(&self, f: impl FnOnce(&mut T) -> R) -> R {
        let mut inner = self.lock();
        let result = f(&mut inner.value);
        inner.fresh = true;
        drop(inner);
        self.changed.notify_all();
        result
    }

    /// A copy of the value as it stands, fresh or not (does not take it).
    pub fn peek(&self) -> T {
        self.lock().value.clone()
    }

    /// Waits up to `timeout` for a fresh value and takes it (a copy; the slot keeps the value,
    /// no longer fresh).
    pub fn wait(&self, timeout: Duration) -> Taken<T> {
        let inner = self.lock();
        let (mut inner, _) = self
            .changed
            .wait_timeout_while(inner, timeout, |i| !i.fresh && !i.closed)
            .unwrap_or_else(|e| e.into_inner());
        if inner.closed {
            return Taken::Closed;
        }
        if !inner.fresh {
            return Taken::Unchanged;
        }
        inner.fresh = false;
        Taken::Fresh(inner.value.clone())
    }

    /// Whether the value changed since it was last taken.
    pub fn is_fresh(&self) -> bool {
        self.lock().fresh
    }

    /// Tells the reader to stop.
    pub fn close(&self) {
        self.lock().closed = true;
        self.changed.notify_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn many_updates_are_taken_once_as_the_newest() {
        let slot = Slot::new(0u32);
        for i in 1..=10_000 {
            slot.update(|v| *v = i);
        }
        assert_eq!(slot.wait(Duration::ZERO), Taken::Fresh(10_000));
        assert_eq!(slot.wait(Duration::from_millis(1)), Taken::Unchanged);
    }

    #[test]
    fn a_waiting_reader_wakes_on_update_and_on_close() {
        let slot = Arc::new(Slot::new(0u32));
        let writer = {
            let slot = slot.clone();
            std::thread::spawn(move || {
                std::thread::sleep(Duration::from_millis(20));
                slot.update(|v| *v = 7);
            })
        };
        assert_eq!(slot.wait(Duration::from_secs(10)), Taken::Fresh(7));
        writer.join().unwrap();
        slot.close();
        assert_eq!(slot.wait(Duration::from_secs(10)), Taken::Closed);
    }
}

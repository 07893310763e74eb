//! The viewer's open connections, at most a fixed number. When it is reached, the
//! connection idle longest (no request being answered) is closed for the newcomer: a
//! client holding many connections open cannot lock anyone out, since each new one
//! pushes out a held one, while a browser's connection is idle only between requests.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;
use tokio::task::AbortHandle;

struct Entry {
    /// The last request's start or end, or the connection's acceptance.
    since: Instant,
    /// Answering a request now.
    busy: bool,
    abort: Option<AbortHandle>,
}

#[derive(Default)]
struct Table {
    next: u64,
    open: HashMap<u64, Entry>,
    evicted: u64,
}

/// The table of open connections.
pub(crate) struct Connections {
    table: Mutex<Table>,
    limit: usize,
}

/// One admitted connection's place in the table, given back when dropped.
pub(crate) struct Ticket {
    id: u64,
    connections: Arc<Connections>,
}

impl Ticket {
    /// Marks the connection as answering a request (`true`) or done with it.
    pub fn busy(&self, busy: bool) {
        if let Some(e) = self.connections.lock().open.get_mut(&self.id) {
            e.busy = busy;
            e.since = Instant::now();
        }
    }

    /// How to close the connection when it is evicted.
    pub fn attach(&self, abort: AbortHandle) {
        if let Some(e) = self.connections.lock().open.get_mut(&self.id) {
            e.abort = Some(abort);
        }
    }
}

impl Drop for Ticket {
    fn drop(&mut self) {
        self.connections.lock().open.remove(&self.id);
    }
}

impl Connections {
    pub fn new(limit: usize) -> Arc<Self> {
        Arc::new(Self {
            table: Mutex::new(Table::default()),
            limit: limit.max(1),
        })
    }

    fn lock(&self) -> MutexGuard<'_, Table> {
        self.table.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Admits a new connection, closing the longest idle one when the table is full.
    pub fn admit(self: &Arc<Self>) -> Ticket {
        let mut t = self.lock();
        while t.open.len() >= self.limit {
            if !Self::evict(&mut t) {
                break;
            }
        }
        let id = t.next;
        t.next += 1;
        t.open.insert(
            id,
            Entry {
                since: Instant::now(),
                busy: false,
                abort: None,
            },
        );
        Ticket {
            id,
            connections: self.clone(),
        }
    }

    /// Closes the longest idle connection (the longest open one when all are busy);
    /// false when there is none.
    fn evict(t: &mut Table) -> bool {
        let victim = t
            .open
            .iter()
            .min_by_key(|(_, e)| (e.busy, e.since))
            .map(|(&id, _)| id);
        let Some(entry) = victim.and_then(|id| t.open.remove(&id)) else {
            return false;
        };
        if let Some(abort) = entry.abort {
            abort.abort();
        }
        t.evicted += 1;
        true
    }

    /// Closes the longest idle connection to free its file descriptor (accept failed
    /// for want of one); false when none is open.
    pub fn shed(&self) -> bool {
        Self::evict(&mut self.lock())
    }

    pub fn open(&self) -> usize {
        self.lock().open.len()
    }

    /// Connections closed to make room since the start.
    pub fn evicted(&self) -> u64 {
        self.lock().evicted
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_table_closes_the_longest_idle_connection_not_a_busy_one() {
        let c = Connections::new(3);
        let a = c.admit();
        let b = c.admit();
        let busy = c.admit();
        busy.busy(true);
        // a is idle longest: b was admitted after it.
        let d = c.admit();
        assert_eq!(c.open(), 3);
        assert_eq!(c.evicted(), 1);
        drop(a); // already gone from the table: dropping its ticket is harmless
        assert_eq!(c.open(), 3);
        let e = c.admit();
        assert_eq!(c.evicted(), 2, "b went, not the busy one");
        drop((b, busy, d, e));
        assert_eq!(c.open(), 0);
    }
}

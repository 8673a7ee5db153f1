//! One thread serving many clients, each with a state of its own: a fleet's
//! vehicles share one FTP thread, one onboard-log thread and one
//! signing-key thread instead of three threads each (153 for 50 vehicles).
//! These threads sleep until asked; a thread per vehicle cost a stack, a
//! scheduler entry and a wake-up per request, and bought nothing.
//!
//! A client's jobs reach its [`Session`] in the order sent. After each
//! burst of jobs every session gets a [`Session::pass`] for work of its own
//! (a flush that is due, a download's next chunks). Dropping a [`Client`]
//! waits until its session has closed (what it held is written). The
//! thread ends once every handle on it is gone; the last one dropped waits
//! for it.
//!
//! A session that panics is dropped alone (its later jobs are discarded
//! and its client's drop returns at once): one vehicle's broken FTP or log
//! session must not end the thread for the rest of the fleet.

use std::collections::BTreeMap;
use std::io;
use std::panic::{self, AssertUnwindSafe};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::thread::JoinHandle;
use std::time::Duration;

/// One client's state on the shared thread.
pub trait Session: Send + 'static {
    type Job: Send + 'static;

    /// One job of this client, in the order the client sent them.
    fn handle(&mut self, job: Self::Job);

    /// Work of its own after a burst of jobs; how soon it wants the next
    /// pass without a job (`None`: not before a job comes).
    fn pass(&mut self) -> Option<Duration>;

    /// The client is gone: finish what is held (called once).
    fn close(&mut self);
}

enum Message<S: Session> {
    Open(u64, S),
    Job(u64, S::Job),
    Close(u64, mpsc::Sender<()>),
}

/// A handle on the thread; clones share it.
pub struct SharedThread<S: Session> {
    tx: Option<mpsc::Sender<Message<S>>>,
    next_id: Arc<AtomicU64>,
    thread: Option<Arc<JoinHandle<()>>>,
}

impl<S: Session> SharedThread<S> {
    /// Starts the thread, named `name`.
    pub fn start(name: &str) -> io::Result<SharedThread<S>> {
        let (tx, rx) = mpsc::channel();
        let thread = std::thread::Builder::new()
            .name(name.into())
            .spawn(move || serve(&rx))?;
        Ok(SharedThread {
            tx: Some(tx),
            next_id: Arc::new(AtomicU64::new(0)),
            thread: Some(Arc::new(thread)),
        })
    }

    /// A new client whose jobs go to `session` on this thread.
    pub fn client(&self, session: S) -> Client<S> {
        let id = self.next_id.fetch_add(1, Ordering::Relaxed);
        let thread = self.clone();
        let open = thread
            .tx
            .as_ref()
            .is_some_and(|tx| tx.send(Message::Open(id, session)).is_ok());
        Client { id, open, thread }
    }
}

impl<S: Session> Clone for SharedThread<S> {
    fn clone(&self) -> Self {
        SharedThread {
            tx: self.tx.clone(),
            next_id: self.next_id.clone(),
            thread: self.thread.clone(),
        }
    }
}

impl<S: Session> std::fmt::Debug for SharedThread<S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SharedThread").finish_non_exhaustive()
    }
}

impl<S: Session> Drop for SharedThread<S> {
    /// The last handle waits for the thread to finish.
    fn drop(&mut self) {
        self.tx.take();
        if let Some(handle) = self.thread.take().and_then(Arc::into_inner) {
            let _ = handle.join();
        }
    }
}

/// One client's end: its jobs go to its session on the thread.
pub struct Client<S: Session> {
    id: u64,
    /// False when the thread was gone at the start.
    open: bool,
    thread: SharedThread<S>,
}

impl<S: Session> Client<S> {
    /// Queues `job` for this client's session; false when the thread has
    /// gone (the job is dropped).
    pub fn send(&self, job: S::Job) -> bool {
        self.open
            && self
                .thread
                .tx
                .as_ref()
                .is_some_and(|tx| tx.send(Message::Job(self.id, job)).is_ok())
    }
}

impl<S: Session> Drop for Client<S> {
    /// Waits until the session has closed.
    fn drop(&mut self) {
        let Some(tx) = self.thread.tx.as_ref().filter(|_| self.open) else {
            return;
        };
        let (ack, closed) = mpsc::channel();
        if tx.send(Message::Close(self.id, ack)).is_ok() {
            // An error here: the thread ended (a panic); nothing to wait for.
            let _ = closed.recv();
        }
    }
}

fn serve<S: Session>(rx: &mpsc::Receiver<Message<S>>) {
    let mut sessions: BTreeMap<u64, S> = BTreeMap::new();
    let mut wait: Option<Duration> = None;
    loop {
        let first = match wait {
            None => match rx.recv() {
                Ok(message) => Some(message),
                Err(_) => break,
            },
            Some(wait) => match rx.recv_timeout(wait) {
                Ok(message) => Some(message),
                Err(RecvTimeoutError::Timeout) => None,
                Err(RecvTimeoutError::Disconnected) => break,
            },
        };
        for message in first.into_iter().chain(rx.try_iter()) {
            dispatch(&mut sessions, message);
        }
        wait = pass_all(&mut sessions);
    }
    for (id, mut session) in std::mem::take(&mut sessions) {
        guarded(id, "close", move || session.close());
    }
}

fn dispatch<S: Session>(sessions: &mut BTreeMap<u64, S>, message: Message<S>) {
    match message {
        Message::Open(id, session) => {
            sessions.insert(id, session);
        }
        Message::Job(id, job) => {
            if let Some(session) = sessions.get_mut(&id)
                && !guarded(id, "job", || session.handle(job))
            {
                drop_failed(sessions, id);
            }
        }
        Message::Close(id, ack) => {
            if let Some(mut session) = sessions.remove(&id) {
                // Dropped inside too: a panicking Drop is the session's alone.
                guarded(id, "close", move || session.close());
            }
            let _ = ack.send(());
        }
    }
}

/// Every session's own pass; the soonest next pass any of them wants.
fn pass_all<S: Session>(sessions: &mut BTreeMap<u64, S>) -> Option<Duration> {
    let mut soonest: Option<Duration> = None;
    let mut failed = Vec::new();
    for (&id, session) in sessions.iter_mut() {
        let mut wanted = None;
        if guarded(id, "pass", || wanted = session.pass()) {
            soonest = soonest.into_iter().chain(wanted).min();
        } else {
            failed.push(id);
        }
    }
    for id in failed {
        drop_failed(sessions, id);
    }
    soonest
}

/// Drops a session that panicked (its own Drop may panic too).
fn drop_failed<S: Session>(sessions: &mut BTreeMap<u64, S>, id: u64) {
    if let Some(session) = sessions.remove(&id) {
        guarded(id, "drop", move || drop(session));
    }
}

/// Runs one session call; false (logged) when it panicked.
fn guarded(id: u64, what: &str, call: impl FnOnce()) -> bool {
    let survived = panic::catch_unwind(AssertUnwindSafe(call)).is_ok();
    if !survived {
        let thread = std::thread::current();
        let name = thread.name().unwrap_or("shared");
        tracing::error!("{name} thread: session {id} panicked in its {what}; it is dropped, the others go on");
    }
    survived
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc::Sender;
    use std::time::Instant;

    /// Records what it was given, in order, and when it was closed.
    struct Recorder {
        name: &'static str,
        seen: Sender<String>,
        passes_wanted: u32,
    }

    /// A job that makes a [`Recorder`] panic, as a session with a bug would.
    const PANICKING_JOB: u32 = u32::MAX;

    impl Session for Recorder {
        type Job = u32;
        fn handle(&mut self, job: u32) {
            assert_ne!(job, PANICKING_JOB, "a session with a bug");
            let _ = self.seen.send(format!("{} {job}", self.name));
        }
        fn pass(&mut self) -> Option<Duration> {
            if self.passes_wanted == 0 {
                return None;
            }
            self.passes_wanted -= 1;
            let _ = self.seen.send(format!("{} pass", self.name));
            Some(Duration::from_millis(1))
        }
        fn close(&mut self) {
            let _ = self.seen.send(format!("{} closed", self.name));
        }
    }

    fn recorder(name: &'static str, seen: &Sender<String>, passes_wanted: u32) -> Recorder {
        Recorder {
            name,
            seen: seen.clone(),
            passes_wanted,
        }
    }

    #[test]
    fn each_client_gets_its_own_jobs_in_order_and_closes_on_drop() {
        let (seen, log) = mpsc::channel();
        let thread = SharedThread::start("test").expect("thread");
        let a = thread.client(recorder("a", &seen, 0));
        let b = thread.client(recorder("b", &seen, 0));
        for job in 0..100 {
            assert!(a.send(job));
            assert!(b.send(1000 + job));
        }
        drop(a);
        // Dropping a client returns once its session has closed.
        let got: Vec<String> = log.try_iter().collect();
        let of_a: Vec<&String> = got.iter().filter(|s| s.starts_with("a ")).collect();
        assert_eq!(of_a.len(), 101, "{got:?}");
        assert!(of_a[..100].iter().enumerate().all(|(i, s)| **s == format!("a {i}")));
        assert_eq!(of_a[100], "a closed");
        drop(b);
        drop(thread);
        let rest: Vec<String> = log.try_iter().collect();
        let of_b: Vec<&String> = got.iter().chain(&rest).filter(|s| s.starts_with("b ")).collect();
        assert_eq!(of_b.len(), 101);
        assert!(
            of_b[..100]
                .iter()
                .enumerate()
                .all(|(i, s)| **s == format!("b {}", 1000 + i))
        );
        assert_eq!(of_b[100], "b closed");
    }

    #[test]
    fn a_session_that_asks_for_passes_gets_them_without_jobs() {
        let (seen, log) = mpsc::channel();
        let thread = SharedThread::start("test").expect("thread");
        let a = thread.client(recorder("a", &seen, 3));
        assert!(a.send(7));
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut passes = 0;
        while passes < 3 {
            assert!(Instant::now() < deadline, "passes: {passes}");
            if let Ok(line) = log.recv_timeout(Duration::from_millis(100)) {
                passes += usize::from(line == "a pass");
            }
        }
        drop(a);
        assert_eq!(log.try_iter().last().as_deref(), Some("a closed"));
    }

    #[test]
    fn the_last_handle_dropped_ends_the_thread_and_closes_what_is_left() {
        let (seen, log) = mpsc::channel();
        let thread = SharedThread::start("test").expect("thread");
        let a = thread.client(recorder("a", &seen, 0));
        assert!(a.send(1));
        drop(thread);
        drop(a);
        let got: Vec<String> = log.try_iter().collect();
        assert_eq!(got, ["a 1", "a closed"]);
    }

    #[test]
    fn a_session_that_panics_is_dropped_alone_and_the_others_go_on() {
        let (seen, log) = mpsc::channel();
        let thread = SharedThread::start("test").expect("thread");
        let broken = thread.client(recorder("broken", &seen, 0));
        let healthy = thread.client(recorder("healthy", &seen, 0));
        assert!(broken.send(1));
        assert!(broken.send(PANICKING_JOB));
        assert!(broken.send(2));
        assert!(healthy.send(3));
        // Its drop returns although its session is gone.
        drop(broken);
        assert!(healthy.send(4));
        drop(healthy);
        drop(thread);
        let got: Vec<String> = log.try_iter().collect();
        assert_eq!(got, ["broken 1", "healthy 3", "healthy 4", "healthy closed"]);
    }
}

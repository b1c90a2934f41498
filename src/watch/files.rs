//! The files a watched scene depends on, and notice of their edits.
//!
//! Only the files the scene actually read are watched (and `shaders/` in a development build),
//! not whole folders: an edit to another file next to the script changes nothing. The watch is
//! on each file's folder, filtered by name, because editors save by writing a temporary file
//! and renaming it over the old one — a new inode, which a watch on the file itself would lose.
//!
//! `notify-debouncer-full` merges each path's raw events and pairs the halves of a rename; on
//! top of it a change is taken only once the watched files have been quiet for the debounce
//! time, so a burst of writes (or the write-then-rename of one save) gives one notice. Reads
//! are not changes (inotify reports every open, refrakt's own reads of the scene included).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::{Duration, Instant};

use anyhow::{Result, anyhow};
use notify::{EventKind, RecommendedWatcher, RecursiveMode};
use notify_debouncer_full::{DebounceEventResult, Debouncer, RecommendedCache, new_debouncer};

/// Edits not yet taken: files of the scene, and shader sources.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Change {
    pub scene: BTreeSet<PathBuf>,
    pub shaders: BTreeSet<PathBuf>,
}

impl Change {
    pub fn is_empty(&self) -> bool {
        self.scene.is_empty() && self.shaders.is_empty()
    }
}

/// How often a wait looks at the stop flag.
const STOP_POLL: Duration = Duration::from_millis(50);
/// The debouncer's window for merging one path's raw events, and how often it looks: short,
/// since the quiet time on top of it is what waits for a burst to end.
const MERGE_MS: u64 = 5;
const TICK_MS: u64 = 2;
const MERGE_WINDOW: Duration = Duration::from_millis(MERGE_MS);
const MERGE_TICK: Duration = Duration::from_millis(TICK_MS);
/// The longest the debouncer holds a raw event before passing it on. Events carry the time
/// they happened, so a change is taken only once this much more than the quiet time has passed
/// since the newest one: any later event of the same burst has arrived by then. (Taking it at
/// `newest + quiet` took a burst of saves 1 ms apart as two or three changes: its later events
/// were still inside the debouncer.)
const DELIVERY: Duration = Duration::from_millis(MERGE_MS + TICK_MS + 1);

pub struct SceneFiles {
    debouncer: Debouncer<RecommendedWatcher, RecommendedCache>,
    notices: Receiver<DebounceEventResult>,
    /// How long the files must be quiet before a change is taken.
    quiet: Duration,
    /// The files that matter, as canonical folder + name (how the watcher reports them).
    files: BTreeSet<PathBuf>,
    /// The folders watched for them.
    folders: BTreeSet<PathBuf>,
    /// `shaders/` of a development checkout: any `.wgsl` below it matters.
    shaders: Option<PathBuf>,
    /// Edits seen and not yet taken, and when the newest of them happened.
    held: Change,
    newest: Option<Instant>,
}

impl SceneFiles {
    /// Watches nothing yet but `shaders` (if given); changes are taken after `quiet`.
    pub fn new(quiet: Duration, shaders: Option<&Path>) -> Result<Self> {
        let (sender, notices) = channel();
        let mut debouncer =
            new_debouncer(MERGE_WINDOW, Some(MERGE_TICK), sender).map_err(|e| anyhow!("cannot watch files: {e}"))?;
        let shaders = match shaders {
            Some(dir) => {
                let dir = dir.canonicalize().map_err(|e| anyhow!("cannot watch {}: {e}", dir.display()))?;
                debouncer
                    .watch(&dir, RecursiveMode::Recursive)
                    .map_err(|e| anyhow!("cannot watch the shaders in {}: {e}", dir.display()))?;
                Some(dir)
            }
            None => None,
        };
        Ok(Self {
            debouncer,
            notices,
            quiet,
            files: BTreeSet::new(),
            folders: BTreeSet::new(),
            shaders,
            held: Change::default(),
            newest: None,
        })
    }

    /// Watches exactly `files` from now on (in place of the earlier set); returns whether the
    /// set changed.
    pub fn watch(&mut self, files: &[PathBuf]) -> Result<bool> {
        let files: BTreeSet<PathBuf> = files.iter().filter_map(|f| canonical_entry(f)).collect();
        if files == self.files {
            return Ok(false);
        }
        let folders: BTreeSet<PathBuf> = files.iter().filter_map(|f| f.parent().map(Path::to_path_buf)).collect();
        for gone in self.folders.difference(&folders) {
            let _ = self.debouncer.unwatch(gone);
        }
        for new in folders.difference(&self.folders) {
            self.debouncer
                .watch(new, RecursiveMode::NonRecursive)
                .map_err(|e| anyhow!("cannot watch the folder {}: {e}", new.display()))?;
        }
        (self.files, self.folders) = (files, folders);
        Ok(true)
    }

    /// The files watched now (shaders aside).
    pub fn watched(&self) -> Vec<PathBuf> {
        self.files.iter().cloned().collect()
    }

    pub fn shaders(&self) -> Option<&Path> {
        self.shaders.as_deref()
    }

    /// Waits until a watched file changed and the files have been quiet since; `None` once
    /// `stop` is set.
    pub fn wait(&mut self, stop: &AtomicBool) -> Option<Change> {
        loop {
            if stop.load(Ordering::SeqCst) {
                return None;
            }
            self.take_arrived();
            let settled = self.newest.map(|t| t + self.quiet + DELIVERY);
            if settled.is_some_and(|t| t <= Instant::now()) {
                self.newest = None;
                return Some(std::mem::take(&mut self.held));
            }
            let patience = settled.map_or(STOP_POLL, |t| t.saturating_duration_since(Instant::now()).min(STOP_POLL));
            match self.notices.recv_timeout(patience) {
                Ok(notice) => self.hold(notice),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return None,
            }
        }
    }

    /// Whether a watched file changed since the last [`wait`](Self::wait), without waiting (the
    /// change is kept for the next wait).
    pub fn changed(&mut self) -> bool {
        self.take_arrived();
        !self.held.is_empty()
    }

    /// Waits up to `time` for a watched file to change; returns whether one did (the change
    /// is kept for the next wait).
    pub fn settle(&mut self, time: Duration) -> bool {
        let until = Instant::now() + time;
        loop {
            if self.changed() {
                return true;
            }
            let left = until.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return false;
            }
            match self.notices.recv_timeout(left.min(MERGE_TICK)) {
                Ok(notice) => self.hold(notice),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return false,
            }
        }
    }

    fn take_arrived(&mut self) {
        while let Ok(notice) = self.notices.try_recv() {
            self.hold(notice);
        }
    }

    fn hold(&mut self, notice: DebounceEventResult) {
        let events = match notice {
            Ok(events) => events,
            Err(errors) => {
                for e in errors {
                    tracing::warn!("watching files: {e}");
                }
                return;
            }
        };
        for event in events.iter().filter(|e| !matches!(e.kind, EventKind::Access(_))) {
            let mut relevant = false;
            for path in &event.paths {
                if self.is_shader(path) {
                    self.held.shaders.insert(path.clone());
                    relevant = true;
                } else if self.files.contains(path) {
                    self.held.scene.insert(path.clone());
                    relevant = true;
                }
            }
            if relevant {
                self.newest = Some(self.newest.map_or(event.time, |t| t.max(event.time)));
            }
        }
    }

    fn is_shader(&self, path: &Path) -> bool {
        self.shaders.as_ref().is_some_and(|d| path.starts_with(d)) && path.extension().is_some_and(|e| e == "wgsl")
    }
}

/// `file` as the watcher names it: its folder made canonical, then its name (the file itself
/// may be missing, or about to be replaced by a rename).
fn canonical_entry(file: &Path) -> Option<PathBuf> {
    let folder = file.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    Some(folder.canonicalize().ok()?.join(file.file_name()?))
}

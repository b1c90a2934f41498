//! `refrakt watch` driven as a user drives it, for the tests: the real binary with `--progress
//! json`, scenes in temporary folders, saves made the ways editors make them.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{Receiver, channel};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde_json::Value;

/// Debounce the tests run with: long against the tight loops of writes that make a burst.
pub const DEBOUNCE_MS: u64 = 300;
/// How long to look for an event that must not come: the debounce, the debouncer's own window,
/// and a margin.
pub const QUIET: Duration = Duration::from_millis(DEBOUNCE_MS + 1700);
/// Longest wait for an event that must come (process start and shader compilation included).
pub const PATIENCE: Duration = Duration::from_secs(180);

/// A glass ball in front of a constant environment, whose color is `ENV`: pixel (0, 0) sees the
/// environment directly, so it shows the color the script asks for.
pub const BALL: &str = r#"local r = require("refrakt")
local scene = r.scene{
  camera = r.camera{ position = {0, 0, 3}, target = {0, 0, 0}, fov = 35, size = {32, 24} },
  environment = r.environment{ color = {ENV} },
  volume = { resolution = 20 },
  samples = 1,
}
scene:add(r.node{ name = "ball", shape = r.sphere{ radius = 0.4 }, material = r.glass{ ior = 1.5 } })
return scene
"#;

pub fn ball(env: &str) -> String {
    BALL.replace("ENV", env)
}

/// A running `refrakt watch` and the JSON events it printed.
pub struct Watch {
    pub child: Child,
    pub events: Receiver<Value>,
    pub stderr: Arc<Mutex<String>>,
    /// Every event so far, for failure messages.
    pub seen: Vec<Value>,
}

impl Watch {
    pub fn start(scene: &Path, out: &Path, extra: &[&str]) -> Self {
        Self::start_with(scene, out, extra, &[])
    }

    pub fn start_with(scene: &Path, out: &Path, extra: &[&str], env: &[(&str, &Path)]) -> Self {
        Self::start_bin(Path::new(env!("CARGO_BIN_EXE_refrakt")), scene, out, extra, env)
    }

    /// [`Watch::start_with`] of the binary `bin` (a copy of refrakt's, elsewhere).
    pub fn start_bin(bin: &Path, scene: &Path, out: &Path, extra: &[&str], env: &[(&str, &Path)]) -> Self {
        let mut cmd = Command::new(bin);
        cmd.args(["watch", scene.to_str().unwrap(), "--out", out.to_str().unwrap(), "--progress", "json"]);
        // The tests' debounce, unless the test gives its own.
        if !extra.contains(&"--debounce") {
            cmd.args(["--debounce", &DEBOUNCE_MS.to_string()]);
        }
        cmd
            .args(extra)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        for (k, v) in env {
            cmd.env(k, v);
        }
        let mut child = cmd.spawn().expect("refrakt starts");
        let (send, events) = channel();
        let stdout = child.stdout.take().unwrap();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                let event = serde_json::from_str(&line).unwrap_or_else(|e| panic!("not a JSON event ({e}): {line}"));
                if send.send(event).is_err() {
                    break;
                }
            }
        });
        let stderr = Arc::new(Mutex::new(String::new()));
        let (pipe, sink) = (child.stderr.take().unwrap(), stderr.clone());
        std::thread::spawn(move || {
            for line in BufReader::new(pipe).lines().map_while(Result::ok) {
                let mut s = sink.lock().unwrap();
                s.push_str(&line);
                s.push('\n');
            }
        });
        Self { child, events, stderr, seen: Vec::new() }
    }

    pub fn history(&self) -> String {
        let events: Vec<String> = self.seen.iter().map(Value::to_string).collect();
        format!("events:\n{}\nstderr:\n{}", events.join("\n"), self.stderr.lock().unwrap())
    }

    /// What `refrakt watch` printed on stderr once it holds `text`, or as it is after
    /// [`PATIENCE`]: stderr is read on its own thread, which may lag the JSON event that comes of
    /// the same message.
    pub fn stderr_once_it_says(&self, text: &str) -> String {
        let deadline = Instant::now() + PATIENCE;
        loop {
            let stderr = self.stderr.lock().unwrap().clone();
            if stderr.contains(text) || Instant::now() > deadline {
                return stderr;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// The next event that is a frame or an error (others are kept in the history).
    pub fn next(&mut self) -> Value {
        let deadline = Instant::now() + PATIENCE;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let Ok(event) = self.events.recv_timeout(left) else {
                panic!("no frame or error event within {PATIENCE:?}\n{}", self.history());
            };
            self.seen.push(event.clone());
            if matches!(event["event"].as_str(), Some("frame" | "error")) {
                return event;
            }
        }
    }

    /// The next frame event; an error event fails the test.
    pub fn frame(&mut self) -> Value {
        let event = self.next();
        assert_eq!(event["event"], "frame", "expected a frame\n{}", self.history());
        event
    }

    /// The next final frame (skipping a fast one before it).
    pub fn final_frame(&mut self) -> Value {
        loop {
            let event = self.frame();
            if event["quality"] == "final" {
                return event;
            }
        }
    }

    pub fn error(&mut self) -> Value {
        let event = self.next();
        assert_eq!(event["event"], "error", "expected an error\n{}", self.history());
        event
    }

    /// Asserts that no frame or error event comes for [`QUIET`].
    pub fn quiet(&mut self, why: &str) {
        let deadline = Instant::now() + QUIET;
        while let Ok(event) = self.events.recv_timeout(deadline.saturating_duration_since(Instant::now())) {
            self.seen.push(event.clone());
            assert!(!matches!(event["event"].as_str(), Some("frame" | "error")), "{why}, yet: {event}\n{}", self.history());
        }
    }

    /// The last `watching` event's files.
    pub fn watched(&self) -> Vec<String> {
        let last = self.seen.iter().rev().find(|e| e["event"] == "watching").expect("a watching event");
        last["files"].as_array().unwrap().iter().map(|f| f.as_str().unwrap().to_string()).collect()
    }

    /// Sends SIGTERM and waits for the exit code.
    #[cfg(unix)]
    pub fn terminate(&mut self) -> i32 {
        let ok = Command::new("kill").args(["-TERM", &self.child.id().to_string()]).status().unwrap();
        assert!(ok.success());
        let deadline = Instant::now() + PATIENCE;
        loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                return status.code().unwrap_or(-1);
            }
            assert!(Instant::now() < deadline, "refrakt watch did not stop after SIGTERM\n{}", self.history());
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Watch {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Saves as editors that write in place do.
pub fn write(path: &Path, text: &str) {
    std::fs::write(path, text).unwrap();
}

/// Saves as editors that write a temporary file and rename it over the old one do.
pub fn save_by_rename(path: &Path, text: &str) {
    let tmp = path.with_extension("swp");
    std::fs::write(&tmp, text).unwrap();
    std::fs::rename(&tmp, path).unwrap();
}

pub fn corner(out: &Path) -> [f32; 4] {
    let image = refrakt::output::exr::read(out).unwrap_or_else(|e| panic!("{e:#}"));
    image.beauty(0, 0)
}

pub fn assert_color(out: &Path, rgb: [f32; 3]) {
    let px = corner(out);
    for c in 0..3 {
        assert!((px[c] - rgb[c]).abs() < 2e-3, "pixel (0, 0) is {px:?}, the script says {rgb:?}");
    }
}

pub fn folder_with(files: &[(&str, &str)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        let path = dir.path().join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        write(&path, text);
    }
    dir
}

pub fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| refrakt::output::is_temporary(n))
        .collect()
}


pub fn copy_tree(from: &Path, to: &Path) {
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target: PathBuf = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            std::fs::create_dir_all(&target).unwrap();
            copy_tree(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}


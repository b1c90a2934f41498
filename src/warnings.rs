//! What refrakt tells a user about a scene it still renders: parts of a file it reads
//! differently or not at all, lights that cannot light what was probably meant. Each is said
//! once, in plain words that name the part of the file and say what refrakt does instead; the
//! same remark about several parts of one file is one line that counts and names them. They go
//! to stderr as text (the default), as JSON lines (`--warnings json`), or nowhere (`--quiet`).

use std::collections::HashSet;
use std::fmt;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU8, Ordering};

/// How warnings are said.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// One line of text each (`refrakt: …` on stderr).
    Text,
    /// One JSON object per line: `{"type": "warning", "at", "file", "message", "subjects", "count"}`.
    Json,
    /// None at all (`--quiet`).
    Quiet,
}

static FORMAT: AtomicU8 = AtomicU8::new(0);

/// Sets how [`say`] speaks, for the whole process (the command line's `--warnings`, `--quiet`).
pub fn set_format(format: Format) {
    FORMAT.store(format as u8, Ordering::Relaxed);
}

fn format() -> Format {
    match FORMAT.load(Ordering::Relaxed) {
        1 => Format::Json,
        2 => Format::Quiet,
        _ => Format::Text,
    }
}

/// Parts of a file one remark is about, named in a line up to this many (then "and n more").
const NAMED: usize = 3;

/// One warning: where the scene asked for it (a script's file:line), which file it concerns,
/// what it says, and which parts of that file it applies to.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct Warning {
    pub at: Option<String>,
    pub file: Option<String>,
    pub message: String,
    /// The materials, meshes, nodes… the message is about, each once, in the file's order.
    pub subjects: Vec<String>,
}

impl Warning {
    /// A warning about the scene as a whole (no file, no parts).
    pub fn plain(message: impl Into<String>) -> Self {
        Self { message: message.into(), ..Self::default() }
    }

    /// The same warning, said as asked for at `at` (a script's `file:line`).
    pub fn at(mut self, at: &str) -> Self {
        self.at = Some(at.to_string());
        self
    }

    fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "type": "warning",
            "at": self.at,
            "file": self.file,
            "message": self.message,
            "subjects": self.subjects,
            "count": self.subjects.len().max(1),
        })
    }
}

/// `at: file: materials[0] "A", materials[2] "B" and 3 more (5 in all): message`.
impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for part in self.at.iter().chain(&self.file) {
            write!(f, "{part}: ")?;
        }
        let n = self.subjects.len();
        if n > 0 {
            write!(f, "{}", self.subjects[..n.min(NAMED)].join(", "))?;
            if n > NAMED {
                write!(f, " and {} more ({n} in all)", n - NAMED)?;
            }
            write!(f, ": ")?;
        }
        write!(f, "{}", self.message)
    }
}

/// A file's warnings as they are found, the same message about several parts kept as one.
#[derive(Debug)]
pub struct Collector {
    file: String,
    warnings: Vec<Warning>,
}

impl Collector {
    /// Collects warnings about the file shown as `file`.
    pub fn new(file: &str) -> Self {
        Self { file: file.to_string(), warnings: Vec::new() }
    }

    /// `message` about the part of the file named `subject` (each part counted once).
    pub fn about(&mut self, subject: impl Into<String>, message: impl Into<String>) {
        let (subject, message) = (subject.into(), message.into());
        match self.warnings.iter_mut().find(|w| w.message == message) {
            Some(w) if !w.subjects.contains(&subject) => w.subjects.push(subject),
            Some(_) => {}
            None => self.warnings.push(Warning { file: Some(self.file.clone()), message, subjects: vec![subject], at: None }),
        }
    }

    /// `message` about the file as a whole (said once however often it is found).
    pub fn file_wide(&mut self, message: impl Into<String>) {
        let message = message.into();
        if !self.warnings.iter().any(|w| w.message == message) {
            self.warnings.push(Warning { file: Some(self.file.clone()), message, ..Warning::default() });
        }
    }

    pub fn into_warnings(self) -> Vec<Warning> {
        self.warnings
    }
}

/// Distinct warnings remembered as said; past this many, later ones are said again each time
/// rather than the memory of a long `serve` growing without end.
const REMEMBERED: usize = 10_000;

/// Says `w` as the command line asked — a text line, a JSON line, or nothing — once per process:
/// a script that imports a file in `update`, or a frame with the same remark, says it once, not
/// every frame.
pub fn say(w: &Warning) {
    static SAID: Mutex<Option<HashSet<Warning>>> = Mutex::new(None);
    {
        let mut said = SAID.lock().unwrap_or_else(|e| e.into_inner());
        let said = said.get_or_insert_with(HashSet::new);
        if said.contains(w) {
            return;
        }
        if said.len() < REMEMBERED {
            said.insert(w.clone());
        }
    }
    match format() {
        Format::Text => tracing::warn!("{w}"),
        Format::Json => eprintln!("{}", w.json()),
        Format::Quiet => {}
    }
}

/// Says a warning about the scene as a whole (a frame's, the server's).
pub fn say_plain(message: &str) {
    say(&Warning::plain(message));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_remark_about_many_parts_is_one_line_that_counts_them() {
        let mut c = Collector::new("car.glb");
        for k in 0..5 {
            c.about(format!("materials[{k}]"), "refrakt does not read X; the factor applies");
        }
        c.about("materials[0]", "refrakt does not read X; the factor applies");
        c.about("materials[1]", "another remark");
        c.file_wide("the extension KHR_y is not read");
        c.file_wide("the extension KHR_y is not read");
        let w = c.into_warnings();
        assert_eq!(w.len(), 3);
        assert_eq!(
            w[0].to_string(),
            "car.glb: materials[0], materials[1], materials[2] and 2 more (5 in all): refrakt does not read X; the factor applies"
        );
        assert_eq!(w[1].to_string(), "car.glb: materials[1]: another remark");
        assert_eq!(w[2].clone().at("scene.lua:3").to_string(), "scene.lua:3: car.glb: the extension KHR_y is not read");
        let json = w[0].json();
        assert_eq!(json["count"], 5);
        assert_eq!(json["subjects"][4], "materials[4]");
        assert_eq!(json["file"], "car.glb");
    }
}

//! Embeds every WGSL file under `shaders/` into the binary (see `src/gpu/shaders.rs`), so a new
//! stage is a new pair of files and nothing else.

use std::path::Path;

fn collect(dir: &Path, base: &Path, out: &mut Vec<String>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir).expect("shaders/ is readable").flatten().collect();
    entries.sort_by_key(|e| e.path());
    for e in entries {
        let path = e.path();
        if path.is_dir() {
            collect(&path, base, out);
        } else if path.extension().is_some_and(|x| x == "wgsl") {
            out.push(path.strip_prefix(base).expect("under shaders/").to_string_lossy().replace('\\', "/"));
        }
    }
}

fn main() {
    let base = Path::new("shaders");
    println!("cargo:rerun-if-changed=shaders");
    let mut files = Vec::new();
    collect(base, base, &mut files);
    let body: String = files.iter().map(|f| format!("    \"{f}\",\n")).collect();
    let code = format!("embedded!(\n{body})\n");
    let out = Path::new(&std::env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("shaders.rs");
    std::fs::write(out, code).expect("OUT_DIR is writable");
}

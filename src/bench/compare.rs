//! `refrakt bench --compare BEFORE.json`: the guard against slowing down. Each scene's GPU frame
//! and each stage (median GPU ms), and each frame flow's frames per second, against an earlier
//! run's; a figure worse than before by more than noise is a regression, and the command fails.
//!
//! Noise is taken from the runs themselves: the larger of [`NOISE_FLOOR`] and each run's
//! relative spread (p90 over median) of that figure. Times under [`TIMER_FLOOR_MS`] are not
//! judged (a timestamp query's resolution and the stage's launch cost dominate them).

use serde_json::Value;

/// The least relative change counted as more than noise.
pub const NOISE_FLOOR: f64 = 0.10;

/// Stage times below this, in milliseconds, before and after, are not judged.
pub const TIMER_FLOOR_MS: f64 = 0.05;

/// The comparison: a line per figure, and the regressions among them.
#[derive(Debug, Default)]
pub struct Comparison {
    pub lines: Vec<String>,
    pub regressions: Vec<String>,
}

/// A median and its relative spread (p90 / median − 1), from a `{median, p90}` object.
fn spread(v: &Value) -> Option<(f64, f64)> {
    let median = v["median"].as_f64()?;
    let p90 = v["p90"].as_f64().unwrap_or(median);
    (median > 0.0).then(|| (median, (p90 / median - 1.0).max(0.0)))
}

/// The noise allowed between two figures: the floor, or the wider of their spreads.
fn noise(before: f64, now: f64) -> f64 {
    NOISE_FLOOR.max(before).max(now)
}

impl Comparison {
    /// Judges a time (lower is better) of `what`, from `{median, p90}` objects.
    fn time(&mut self, what: &str, now: &Value, before: &Value) {
        let (Some((b, b_spread)), Some((n, n_spread))) = (spread(before), spread(now)) else { return };
        let allowed = noise(b_spread, n_spread);
        let line = format!("{what}: {b:.3} → {n:.3} ms ({:.2}×, noise ±{:.0} %)", n / b, 100.0 * allowed);
        if n > b * (1.0 + allowed) && b.max(n) >= TIMER_FLOOR_MS {
            self.regressions.push(line.clone());
        }
        self.lines.push(line);
    }

    /// Judges a rate (higher is better) of `what`.
    fn rate(&mut self, what: &str, now: f64, before: f64) {
        if before <= 0.0 || now <= 0.0 {
            return;
        }
        let line = format!("{what}: {before:.1} → {now:.1} frames/s ({:.2}×, noise ±{:.0} %)", now / before, 100.0 * NOISE_FLOOR);
        if now * (1.0 + NOISE_FLOOR) < before {
            self.regressions.push(line.clone());
        }
        self.lines.push(line);
    }
}

fn array(v: &Value) -> Vec<Value> {
    v.as_array().cloned().unwrap_or_default()
}

/// Compares this run (`now`) with an earlier one, figure by figure, where both have it.
pub fn compare(now: &Value, before: &Value) -> Comparison {
    let mut c = Comparison::default();
    for s in array(&now["scenes"]) {
        let name = s["name"].as_str().unwrap_or("?");
        let Some(old) = array(&before["scenes"]).into_iter().find(|o| o["name"] == s["name"]) else { continue };
        c.time(&format!("{name}: GPU frame"), &s["gpu_ms"], &old["gpu_ms"]);
        for (stage, t) in s["stages_ms"].as_object().into_iter().flatten() {
            c.time(&format!("{name}: {stage}"), t, &old["stages_ms"][stage]);
        }
    }
    for f in array(&now["frame_output"]["flows"]) {
        let Some(old) = array(&before["frame_output"]["flows"]).into_iter().find(|o| o["flow"] == f["flow"]) else { continue };
        let fps = |v: &Value| v["fps"].as_f64().unwrap_or(0.0);
        c.rate(&format!("frames, {}", f["flow"].as_str().unwrap_or("?")), fps(&f), fps(&old));
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn run(march: (f64, f64), view: (f64, f64), fps: f64) -> Value {
        let t = |(median, p90): (f64, f64)| json!({ "median": median, "p90": p90 });
        json!({
            "scenes": [{ "name": "seed", "gpu_ms": t((march.0 + view.0, march.1 + view.1)),
                         "stages_ms": { "march": t(march), "view": t(view), "gradient": t((0.01, 0.01)) } }],
            "frame_output": { "flows": [{ "flow": "exr none", "fps": fps }] },
        })
    }

    #[test]
    fn a_stage_slower_beyond_noise_is_a_regression_and_noise_is_not() {
        let before = run((2.0, 2.1), (1.0, 1.02), 150.0);
        // The same within noise (5 %), a timer-resolution stage tripled: nothing to report.
        let same = compare(&run((2.1, 2.2), (1.04, 1.05), 140.0), &before);
        assert!(same.regressions.is_empty(), "{:?}", same.regressions);
        assert!(same.lines.iter().any(|l| l.starts_with("seed: march")), "{:?}", same.lines);
        // The march 40 % slower with a tight spread, and frames/s down by a third.
        let slower = compare(&run((2.8, 2.9), (1.0, 1.02), 100.0), &before);
        let flagged: Vec<&str> = slower.regressions.iter().map(|r| r.split(':').next().unwrap()).collect();
        assert_eq!(flagged, ["seed", "seed", "frames, exr none"], "{:?}", slower.regressions);
        assert!(slower.regressions[1].starts_with("seed: march"), "{:?}", slower.regressions);
        // The same 40 % where the run itself spread by 60 %: within its noise.
        let noisy = compare(&run((2.8, 4.5), (1.0, 1.02), 150.0), &before);
        assert!(noisy.regressions.iter().all(|r| !r.contains("march")), "{:?}", noisy.regressions);
    }

    #[test]
    fn scenes_and_flows_missing_from_either_run_are_left_out() {
        let before = json!({ "scenes": [{ "name": "grin", "gpu_ms": { "median": 1.0, "p90": 1.0 } }] });
        let c = compare(&run((2.0, 2.0), (1.0, 1.0), 100.0), &before);
        assert!(c.lines.is_empty() && c.regressions.is_empty(), "{:?}", c.lines);
    }
}

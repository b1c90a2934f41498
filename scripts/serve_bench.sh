#!/usr/bin/env bash
# The figures of issue #19 on a GPU machine: `refrakt bench --scenes serve` (the seed scene at
# 1024×576 through the real server and a WebSocket client: frames/s while orbiting and while
# dragging a light, and the split render / readback / encode / delivery), then — where Chromium
# and chromedriver are installed — the frames/s a headless browser draws while its mouse orbits
# examples/default.lua (1024×576). Writes render/serve_bench.json.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
cargo build --release --locked
mkdir -p render
target/release/refrakt bench --scenes serve --out render/serve_bench.json "$@" >/dev/null
python3 - <<'PY'
import json
d = json.load(open("render/serve_bench.json"))["serve"]
print(f"adapter: {json.load(open('render/serve_bench.json'))['adapter']}, size {d['size']}")
for phase in ("orbit", "light_drag"):
    p = d[phase]
    m = lambda k: p[k]["median"] if p.get(k) else float("nan")
    print(f"{phase:10s} {p['frames_per_second']:6.1f} frames/s  render {m('render_ms'):.2f}  readback {m('readback_ms'):.2f}  "
          f"encode {m('encode_ms'):.2f}  delivery {m('delivery_ms'):.2f}  latency {m('latency_ms'):.2f} ms  "
          f"(reused volume {p['reused_volume']}/{p['frames']}, photons {p['reused_photons']}/{p['frames']}, {p['frame_kib']:.0f} KiB/frame)")
PY
if command -v chromedriver >/dev/null 2>&1; then
  python3 scripts/test_browser.py target/release/refrakt --scene examples/default.lua --measure 10
else
  echo "serve_bench: no chromedriver here; the browser run is skipped" >&2
fi

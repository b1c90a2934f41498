#!/usr/bin/env python3
"""Markdown tables from `refrakt bench` JSON files, for the guide's performance page (docs/performance.md).

    python3 scripts/bench_table.py h200.json [lavapipe.json …]

One row per scene and adapter: settings, each stage's median GPU time, the whole frame's GPU time
(median and p90), frames per second of GPU time, wall time per frame, and the march and view
stages as a fraction of the bare kernels on the same adapter. Then, for files that have them, the
seed scaling sweeps, the photon count against caustic noise curve, the voxelize-only figures and
`refrakt watch`'s edit-to-image latency and `refrakt render --frames`' frames on disk per second
(`--scenes frames`). Standard library only.
"""

import json
import sys

STAGES = ["voxelize.meshes", "voxelize", "gradient", "octree", "photons", "march", "caustics", "indirect", "view"]


def ms(value):
    return "—" if value is None else f"{value:.2f}"


def adapter(report):
    return report["adapter"].split(" (")[0]


def photons(settings):
    """The photons a frame traces: the caustic ones and the bounce population where the bench
    says (newer reports), else the scene's `photons`."""
    traced = settings.get("photons_traced")
    if not traced:
        return f"{settings['photons']:,} photons"
    if not traced["bounce"]:
        return f"{traced['caustic']:,} photons"
    return f"{traced['caustic']:,} + {traced['bounce']:,} bounce photons"


def scene_rows(report):
    rows = []
    for s in report["scenes"]:
        if "stages_ms" not in s:
            if "skipped" in s:
                rows.append(f"| {s['name']} | {adapter(report)} | skipped: {s['skipped']} |" + " |" * (len(STAGES) + 5))
            continue
        st = s["settings"]
        settings = f"{st['size'][0]}×{st['size'][1]}, {'×'.join(map(str, st['volume']))}, {photons(st)}" + (
            f", {st['triangles']:,} tris" if st["triangles"] else "") + (", fog" if st["fog"] else "") + (
            f", {st['environment_shadow_rays']} sky shadow rays" if st.get("environment_shadow_rays") else "")
        stages = [ms(s["stages_ms"].get(k, {}).get("median")) for k in STAGES]
        frac = s.get("fraction_of_bare_kernels") or {}
        pct = lambda v: "—" if v is None else f"{100 * v:.1f}%"
        rows.append(
            f"| {s['name']} | {adapter(report)} | {settings} | " + " | ".join(stages)
            + f" | **{ms(s['gpu_ms']['median'])}** / {ms(s['gpu_ms']['p90'])} | {s['gpu_fps']:.0f} | {ms(s['wall_ms']['median'])}"
            + f" | {pct(frac.get('march'))} / {pct(frac.get('view'))} |"
        )
    return rows


def scenes_table(reports):
    head = "| scene | adapter | settings | " + " | ".join(STAGES) + " | GPU ms (median / p90) | GPU fps | wall ms | march / view of bare |"
    rule = "|" + " --- |" * (len(STAGES) + 7)
    out = [head, rule]
    for r in reports:
        out += scene_rows(r)
    return out


def table(title, columns, rows):
    """A titled Markdown table: `rows` are lists of cells, one per column."""
    lines = [title, "", "| " + " | ".join(columns) + " |", "|" + " --- |" * len(columns)]
    return lines + ["| " + " | ".join(row) + " |" for row in rows]


def scaling_table(report):
    rows = report.get("seed_scaling") or []
    if not rows:
        return []
    cells = []
    for r in rows:
        st = r["settings"]
        value = {"photons": f"{st['photons']:,}", "volume": "×".join(map(str, st["volume"])),
                 "image": f"{st['size'][0]}×{st['size'][1]}", "triangles": f"{st['triangles']:,}"}[r["sweep"]]
        if "skipped" in r:
            cells.append([r["sweep"], value, f"skipped: {r['skipped']}"] + [""] * 6)
            continue
        g = r["stages_ms"].get
        cells.append([r["sweep"], value, f"{st['photons']:,}", ms(g("march")), ms(g("view")), ms(g("voxelize.meshes")),
                      ms(g("octree")), ms(g("caustics")), ms(r["gpu_ms"])])
    return table(f"Seed scaling on {adapter(report)} (one setting changed at a time; median GPU ms):",
                 ["sweep", "value", "photons", "march", "view", "voxelize.meshes", "octree", "caustics", "GPU total"], cells)


def quality_table(report):
    q = report.get("seed_quality")
    if not q:
        return []
    return table(f"Caustic noise against photon count on {adapter(report)} (RMSE of the caustic layer to a "
                 f"{q['reference_photons']:,}-photon reference, W/m²):",
                 ["photons", "photon stages ms", "caustic RMSE"],
                 [[f"{p['photons']:,}", f"{p['photon_stages_ms']:.2f}", f"{p['caustic_rmse']:.4f}"] for p in q["points"]])


def voxelize_table(report):
    v = report.get("voxelize") or []
    if not v:
        return []
    cells = []
    for m in v:
        if "skipped" in m:
            cells.append([m["mesh"], "", f"{m['resolution']}³", f"skipped: {m['skipped']}", "", ""])
        else:
            cells.append([m["mesh"], f"{m['triangles']:,}", "×".join(map(str, m["volume"])), f"{m['meshes_ms']:.2f}",
                          f"{m['composite_ms']:.2f}", f"**{m['voxelize_ms']:.2f}**"])
    return table(f"Voxelize stage alone on {adapter(report)} (median of 5, solids computed afresh):",
                 ["mesh", "triangles", "volume", "mesh solid ms", "composite ms", "voxelize ms"], cells)


def latency_table(report):
    w = report.get("watch_latency")
    if not w:
        return []
    spread = lambda t: f"{t['median']:.1f} / {t['p90']:.1f}"
    cells = [[kind.replace("_", " "), spread(w[kind]["first_image_ms"]), spread(w[kind]["final_image_ms"]),
              spread(w["without_fast_frame"][kind]["final_image_ms"])] for kind in ("camera_edit", "object_edit")]
    return table(f"`refrakt watch` on {adapter(report)}, save to preview in place (median / p90 ms; "
                 f"{w['edits']} edits each, {w['debounce_ms']:.0f} ms debounce):",
                 ["edit", "fast frame first", "then the full frame", "full frame alone"], cells)


def frames_table(report):
    f = report.get("frame_output")
    if not f:
        return []
    cells = []
    for r in f["flows"]:
        m = r["ms_per_frame"]
        cells.append([r["flow"], str(r["frames_in_flight"]), str(r["writers"]), f"**{r['fps']:.1f}**", f"{r['mb_per_frame']:.1f}",
                      ms(m["gpu"]), ms(m["evaluate"]), ms(m["submit"]), ms(m["gpu_wait"]), ms(m["readback"]), ms(m["queue_wait"]),
                      ms(m.get("convert", 0.0)), ms(m["encode"]), ms(m["write"]), f"{r['bound']['by']} ({r['bound']['ms_per_frame']:.2f} ms)"])
    enc = f.get("encode")
    lines = []
    if enc:
        size = "×".join(map(str, enc["size"]))
        cells2 = [[r["format"] + (f" {r['compression']}" + (" half" if r["half"] else "") if r["format"] == "exr" else ""),
                   f"{r['encode_ms']:.1f}", f"{r['mb']:.2f}", f"{1e3 / r['encode_ms']:.0f}" if r["encode_ms"] > 0 else "—"]
                  for r in enc["one_core"]]
        lines = table(f"Encoding one {size} frame of {f['scene']} on one core of {adapter(report)}'s host (median of 3):",
                      ["file", "encode ms", "MB", "frames/s per core"], cells2) + [""]
    return lines + table(f"`refrakt render --frames` end to end on {adapter(report)}, {f['settings']['frames']} frames of "
                 f"{f['scene']}, {f['settings']['cores']} cores (ms per frame; convert, encode and write summed over the writers):",
                 ["flow", "in flight", "writers", "frames/s", "MB/frame", "GPU", "evaluate", "submit", "GPU wait", "readback",
                  "queue wait", "convert", "encode", "write", "bound by"], cells)


def main(paths):
    reports = [json.load(open(p)) for p in paths]
    lines = scenes_table(reports)
    for r in reports:
        for table in (voxelize_table(r), scaling_table(r), quality_table(r), latency_table(r), frames_table(r)):
            if table:
                lines += [""] + table
    print("\n".join(lines))


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])

#!/usr/bin/env python3
"""Markdown tables from `refrakt bench` JSON files, for the README's performance section.

    python3 scripts/bench_table.py h200.json [lavapipe.json …]

One row per scene and adapter: settings, each stage's median GPU time, the whole frame's GPU time
(median and p90), frames per second of GPU time, wall time per frame, and the march and view
stages as a fraction of the bare kernels on the same adapter. Then, for files that have them, the
seed scaling sweeps, the photon count against caustic noise curve, the voxelize-only figures and
`refrakt watch`'s edit-to-image latency. Standard library only.
"""

import json
import sys

STAGES = ["voxelize.meshes", "voxelize", "gradient", "octree", "photons", "march", "caustics", "view"]


def ms(value):
    return "—" if value is None else f"{value:.2f}"


def adapter(report):
    return report["adapter"].split(" (")[0]


def scene_rows(report):
    rows = []
    for s in report["scenes"]:
        if "stages_ms" not in s:
            if "skipped" in s:
                rows.append(f"| {s['name']} | {adapter(report)} | skipped: {s['skipped']} |" + " |" * (len(STAGES) + 5))
            continue
        st = s["settings"]
        settings = f"{st['size'][0]}×{st['size'][1]}, {'×'.join(map(str, st['volume']))}, {st['photons']:,} photons" + (
            f", {st['triangles']:,} tris" if st["triangles"] else "") + (", fog" if st["fog"] else "")
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


def scaling_table(report):
    rows = report.get("seed_scaling") or []
    if not rows:
        return []
    out = [f"Seed scaling on {adapter(report)} (one setting changed at a time; median GPU ms):", "",
           "| sweep | value | photons | march | view | voxelize.meshes | octree | caustics | GPU total |",
           "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        st = r["settings"]
        value = {"photons": f"{st['photons']:,}", "volume": "×".join(map(str, st["volume"])),
                 "image": f"{st['size'][0]}×{st['size'][1]}", "triangles": f"{st['triangles']:,}"}[r["sweep"]]
        if "skipped" in r:
            out.append(f"| {r['sweep']} | {value} | skipped: {r['skipped']} | | | | | | |")
            continue
        g = r["stages_ms"].get
        out.append(f"| {r['sweep']} | {value} | {st['photons']:,} | {ms(g('march'))} | {ms(g('view'))} | {ms(g('voxelize.meshes'))} "
                   f"| {ms(g('octree'))} | {ms(g('caustics'))} | {ms(r['gpu_ms'])} |")
    return out


def quality_table(report):
    q = report.get("seed_quality")
    if not q:
        return []
    out = [f"Caustic noise against photon count on {adapter(report)} (RMSE of the caustic layer to a "
           f"{q['reference_photons']:,}-photon reference, W/m²):", "",
           "| photons | photon stages ms | caustic RMSE |", "| --- | --- | --- |"]
    out += [f"| {p['photons']:,} | {p['photon_stages_ms']:.2f} | {p['caustic_rmse']:.4f} |" for p in q["points"]]
    return out


def voxelize_table(report):
    v = report.get("voxelize") or []
    if not v:
        return []
    out = [f"Voxelize stage alone on {adapter(report)} (median of 5, solids computed afresh):", "",
           "| mesh | triangles | volume | mesh solid ms | composite ms | voxelize ms |", "| --- | --- | --- | --- | --- | --- |"]
    for m in v:
        if "skipped" in m:
            out.append(f"| {m['mesh']} | | {m['resolution']}³ | skipped: {m['skipped']} | | |")
        else:
            out.append(f"| {m['mesh']} | {m['triangles']:,} | {'×'.join(map(str, m['volume']))} | {m['meshes_ms']:.2f} "
                       f"| {m['composite_ms']:.2f} | **{m['voxelize_ms']:.2f}** |")
    return out


def latency_table(report):
    w = report.get("watch_latency")
    if not w:
        return []
    out = [f"`refrakt watch` on {adapter(report)}, save to preview in place (median / p90 ms; "
           f"{w['edits']} edits each, {w['debounce_ms']:.0f} ms debounce):", "",
           "| edit | fast frame first | then the full frame | full frame alone |", "| --- | --- | --- | --- |"]
    spread = lambda t: f"{t['median']:.1f} / {t['p90']:.1f}"
    for kind in ("camera_edit", "object_edit"):
        e, alone = w[kind], w["without_fast_frame"][kind]
        out.append(f"| {kind.replace('_', ' ')} | {spread(e['first_image_ms'])} | {spread(e['final_image_ms'])} | {spread(alone['final_image_ms'])} |")
    return out


def main(paths):
    reports = [json.load(open(p)) for p in paths]
    lines = scenes_table(reports)
    for r in reports:
        for table in (voxelize_table(r), scaling_table(r), quality_table(r), latency_table(r)):
            if table:
                lines += [""] + table
    print("\n".join(lines))


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])

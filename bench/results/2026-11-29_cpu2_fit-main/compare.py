"""before/ and after/ path_cases.json side by side (AB and RM rows), as compare.md."""
import json
import pathlib

HERE = pathlib.Path(__file__).resolve().parent
b, a = (json.load(open(HERE / d / "path_cases.json"))["cases"] for d in ("before", "after"))
print("| case | grid | motion (vox) | noise mm | method | before: vs true RMS / max % | vs logged | segments (true) | ms "
      "| after: vs true | vs logged | segments (true) | ms |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for cb, ca in zip(b, a):
    assert cb["name"] == ca["name"]
    for rb, ra in zip(cb["rows"], ca["rows"]):
        cells = [cb["name"], cb["grid"], f"{cb['size_vox']:.2f}", f"{cb['noise_mm']:.3f}", rb["method"]]
        for r in (rb, ra):
            cells += [f"{r['true_rms_pct']:.3f} / {r['true_max_pct']:.3f}", f"{r['logged_rms_pct']:.3f} / {r['logged_max_pct']:.3f}",
                      f"{r['segments']} ({r['segments_true']})", f"{r['ms']:.1f}"]
        print("| " + " | ".join(cells) + " |")

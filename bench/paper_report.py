#!/usr/bin/env python3
"""The paper's Tables 1-3 beside ours: reads what bench/paper.sh measured in
RUN_DIR and writes RUN_DIR/paper.md (a table per phantom laid out like the
paper's, the peers, AB's physical floor and the issue's targets), paper.csv
(every measured number in one long table) and plot-PHANTOM.png (error against
time per motion, one point per method, the paper's points faded beside ours).

  paper_report.py RUN_DIR [--paper bench/paper_tables.csv]

RUN_DIR holds results.csv (petblur bench on the GPU), and where measured
results-pocl.csv (petblur bench on the CPU through PoCL), peers.csv
(bench/peers.py) and rates.csv (bench/fetch_rate.cu). Plots need matplotlib;
without it the tables are still written and the report says so."""
import argparse
import csv
import math
import os
import sys

NAMES = {"homogeneity": "Homogeneity phantom (Table 1)", "derenzo": "Derenzo phantom (Table 2)",
         "brain": "Brain phantom (Table 3)"}
METHODS = [("CL", "hardware"), ("RM", "hardware"), ("AB", "hardware"), ("AB", "exact"), ("RM", "exact"),
           ("CL", "exact"), ("AB-E", "hardware"), ("AB-E", "exact"), ("RM-E", "hardware"), ("RM-E", "exact")]
COLOURS = {"CL": "#1f77b4", "RM": "#2ca02c", "AB": "#d62728", "AB-E": "#ff7f0e", "RM-E": "#17becf",
           "torch": "#9467bd", "scipy": "#8c564b"}


def read_csv(path):
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(row for row in f if not row.startswith("#"))]
    # The paper's tables are in its eq. (5): eq5_pct since the bench also
    # reports relative RMS and max; error_pct in runs made before.
    for r in rows:
        if "eq5_pct" in r:
            r["error_pct"] = r["eq5_pct"]
    return rows


def num(v):
    try:
        x = float(v)
    except (TypeError, ValueError):
        return None
    return None if math.isnan(x) else x


def fmt(v, digits=4):
    return "" if v is None else ("%.*f" % (digits, v))


def motion(r):
    t = "(%g, %g, %g)" % (float(r["tx"]), float(r["ty"]), float(r["tz"]))
    return t + ("" if float(r["rot_deg"]) == 0 else ", %g°" % float(r["rot_deg"]))


class Run:
    def __init__(self, d, paper):
        self.ours = {(r["phantom"], int(r["scenario"]), r["method"], r["filter"]): r
                     for r in read_csv(os.path.join(d, "results.csv"))}
        self.pocl = {(r["phantom"], int(r["scenario"]), r["method"], r["filter"]): r
                     for r in read_csv(os.path.join(d, "results-pocl.csv"))}
        self.peers = {(r["phantom"], int(r["scenario"]), r["peer"]): r for r in read_csv(os.path.join(d, "peers.csv"))}
        self.paper = {(r["phantom"], int(r["scenario"])): r for r in read_csv(paper)}
        rates = read_csv(os.path.join(d, "rates.csv"))
        fetch = [num(r["rate"]) for r in rates if r["kind"] == "trilinear3d"]
        layered = [num(r["rate"]) for r in rates if r["kind"] == "bilinear_layered"]
        copy = [num(r["rate"]) for r in rates if r["kind"] == "copy"]
        self.fetch_rate = max(fetch) if fetch else None  # G fetches/s, the best the texture unit did
        self.layered_rate = max(layered) if layered else None
        self.bandwidth = max(copy) if copy else None      # GB/s, read + write of a copy
        self.phantoms = [p for p in NAMES if any(k[0] == p for k in self.ours)]

    def get(self, table, p, s, m, f, col):
        r = table.get((p, s, m, f))
        return num(r[col]) if r else None

    def scenarios(self, p):
        return sorted({k[1] for k in self.ours if k[0] == p})

    def floor_ms(self, p, s):
        """AB's physical floor: its fetches over the texture unit's rate for
        the kind it makes, or its bytes (the volume read once, the result
        written once) over the copy bandwidth, whichever is longer. Under a
        translation the library reads 2-D layers, bilinear (cl/pb_shift.cl),
        but for short walks along x; otherwise 3-D trilinear fetches."""
        r = self.ours.get((p, s, "AB", "hardware"))
        rate = self.layered_rate if r and layered_walk(r) else self.fetch_rate
        if not r or not rate or not self.bandwidth:
            return None
        n = int(r["nx"]) * int(r["ny"]) * int(r["nz"])
        return max(float(r["ab_fetches"]) / (rate * 1e6), 8.0 * n / (self.bandwidth * 1e6))


def layered_walk(r):
    """Whether the library walks AB HARDWARE through 2-D layers for this row's
    motion: a translation (one segment from the identity; the bench gives it in
    voxels) that moves most along y or z, or along x by at least 8 voxels
    (src/devices/kernel_choice.c), ties going to the lower axis as in the kernels."""
    if num(r["rot_deg"]) != 0.0:
        return False
    d = [abs(num(r[t])) for t in ("tx", "ty", "tz")]
    m = 1 if d[1] > d[0] else 0
    m = 2 if d[2] > d[m] else m
    return m >= 1 or d[0] >= 8.0


def phantom_tables(run, p):
    first = next(r for k, r in run.ours.items() if k[0] == p)
    out = ["## %s: %s x %s x %s voxels of %s x %s x %s mm" % (NAMES[p], first["nx"], first["ny"], first["nz"],
                                                                 first["vx"], first["vy"], first["vz"]), ""]
    dagger = False
    out += ["Error % (eq. 5) against REF. Ours: HARDWARE filter unless marked EX; the paper's: GTX 960M. "
            "AB and RM walk one segment per frame, as the paper's; AB-E and RM-E cut it to petblur's default path "
            "error bound (segments: how many). REF noise: the error between two references of different seeds; "
            "an error below it (marked †) is not resolved by the reference.", "",
            "| # | motion | REF noise | CL | CL paper | RM | RM paper | AB | AB paper | AB EX | AB-E | RM-E | "
            "segments | PyTorch | SciPy |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in run.scenarios(p):
        noise = run.get(run.ours, p, s, "REF", "exact", "error_pct")
        pap = run.paper.get((p, s), {})

        def mark(v):
            nonlocal dagger
            if v is None:
                return ""
            if noise is not None and v < noise:
                dagger = True
                return fmt(v) + " †"
            return fmt(v)
        row = run.ours[(p, s, "REF", "exact")]
        cells = [str(s), motion(row), fmt(noise)]
        for m in ("CL", "RM", "AB"):
            cells += [mark(run.get(run.ours, p, s, m, "hardware", "error_pct")), fmt(num(pap.get("error_" + m.lower())))]
        cells.append(mark(run.get(run.ours, p, s, "AB", "exact", "error_pct")))
        cells.append(mark(run.get(run.ours, p, s, "AB-E", "hardware", "error_pct")))
        cells.append(mark(run.get(run.ours, p, s, "RM-E", "hardware", "error_pct")))
        seg = run.ours.get((p, s, "AB-E", "hardware"))
        cells.append(seg["segments"] if seg else "")
        for peer in ("torch", "scipy"):
            r = run.peers.get((p, s, peer))
            cells.append(mark(num(r["error_pct"])) if r else "")
        out.append("| " + " | ".join(cells) + " |")
    out += ["", "Time in ms. Ours: kernel time from device events (median after a warm-up); AB e2e adds the upload "
            "and download; AB adjoint: pb_blur_adjoint of the same motion (the transpose, for back projection), "
            "zeroing of its output included, or under translations the copy of its input into a texture; PyTorch: "
            "its S poses of affine_grid + grid_sample, CUDA events. Floor: AB's fetches over the texture unit's "
            "measured rate for the kind it makes (2-D layered bilinear under a translation, 3-D "
            "trilinear otherwise), or its bytes over the measured bandwidth, whichever is longer.", "",
            "| # | S | CL | CL paper | RM | RM paper | AB | AB paper | AB EX | AB e2e | AB-E | AB-E / AB | AB adjoint | "
            "adjoint / AB | PyTorch | PyTorch / AB | AB floor | AB / floor |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in run.scenarios(p):
        pap = run.paper.get((p, s), {})
        ab = run.get(run.ours, p, s, "AB", "hardware", "kernel_ms")
        cells = [str(s), run.ours[(p, s, "REF", "exact")]["ab_max_slices"]]
        for m in ("CL", "RM", "AB"):
            cells += [fmt(run.get(run.ours, p, s, m, "hardware", "kernel_ms"), 3),
                      fmt(num(pap.get("time_" + m.lower())), 2)]
        cells += [fmt(run.get(run.ours, p, s, "AB", "exact", "kernel_ms"), 3),
                  fmt(run.get(run.ours, p, s, "AB", "hardware", "e2e_ms"), 3)]
        abe = run.get(run.ours, p, s, "AB-E", "hardware", "kernel_ms")
        cells += [fmt(abe, 3), fmt(abe / ab if abe and ab else None, 2)]
        adj = run.get(run.ours, p, s, "AB", "hardware", "adjoint_ms")
        cells += [fmt(adj, 3), fmt(adj / ab if adj and ab else None, 2)]
        t = run.peers.get((p, s, "torch"))
        tt = num(t["time_ms"]) if t else None
        cells += [fmt(tt, 3), fmt(tt / ab if tt and ab else None, 1)]
        fl = run.floor_ms(p, s)
        cells += [fmt(fl, 3), fmt(ab / fl if fl and ab else None, 2)]
        out.append("| " + " | ".join(cells) + " |")
    if dagger:
        out += ["", "† below the reference's own noise."]
    return "\n".join(out) + "\n"


def cpu_table(run):
    keys = sorted({(k[0], k[1]) for k in run.pocl})
    if not keys:
        return ""
    dev = next(iter(run.pocl.values()))["device"]
    out = ["## On the CPU: petblur through PoCL against SciPy", "",
           "petblur on %s (all cores) against SciPy map_coordinates (one thread, as a user calls it), on the same "
           "volume, motion, S and reference. Times in ms (PoCL: kernel time from profiling events; SciPy: wall "
           "clock of the whole blur)." % dev, "",
           "| phantom | # | S | AB HW | AB EX | RM HW | CL HW | SciPy | SciPy / AB HW | SciPy / AB EX | "
           "error AB HW | error SciPy |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for p, s in keys:
        sc = run.peers.get((p, s, "scipy"))
        st = num(sc["time_ms"]) if sc else None
        ab = run.get(run.pocl, p, s, "AB", "hardware", "kernel_ms")
        ex = run.get(run.pocl, p, s, "AB", "exact", "kernel_ms")
        out.append("| " + " | ".join([
            p, str(s), run.pocl[(p, s, "AB", "hardware")]["ab_max_slices"], fmt(ab, 2), fmt(ex, 2),
            fmt(run.get(run.pocl, p, s, "RM", "hardware", "kernel_ms"), 2),
            fmt(run.get(run.pocl, p, s, "CL", "hardware", "kernel_ms"), 2), fmt(st, 1),
            fmt(st / ab if st and ab else None, 1), fmt(st / ex if st and ex else None, 1),
            fmt(run.get(run.pocl, p, s, "AB", "hardware", "error_pct")),
            fmt(num(sc["error_pct"]) if sc else None)]) + " |")
    return "\n".join(out) + "\n"


def targets(run):
    out = ["## Targets", ""]
    for p in run.phantoms:
        worse = []
        for s in (1, 2, 3, 4):
            e = run.get(run.ours, p, s, "AB", "hardware", "error_pct")
            pap = num(run.paper.get((p, s), {}).get("error_ab"))
            if e is not None and pap is not None and e > pap:
                worse.append("%d (%.4f > %.4f)" % (s, e, pap))
        have = [s for s in (1, 2, 3, 4) if (p, s, "AB", "hardware") in run.ours]
        if have:
            out.append("- AB error at or below the paper's, translations (1-4), %s: %s" % (
                p, "met" if not worse else "NOT met in " + ", ".join(worse)))
    for p in run.phantoms:
        bad = []
        for s in (6, 8):
            e = run.get(run.ours, p, s, "AB-E", "hardware", "error_pct")
            t, t1 = (run.get(run.ours, p, s, m, "hardware", "kernel_ms") for m in ("AB-E", "AB"))
            if e is None or t is None or t1 is None:
                continue
            if e > 0.5 or t > 1.5 * t1:
                bad.append("%d (%.3f %%, %.2fx)" % (s, e, t / t1))
        if any((p, s, "AB-E", "hardware") in run.ours for s in (6, 8)):
            out.append("- AB with the default path error bound, scenarios 6 and 8, %s: error at most 0.5 %% and time "
                       "at most 1.5x one-segment AB: %s" % (p, "met" if not bad else "NOT met in " + ", ".join(bad)))
    adj = [(num(r["adjoint_ms"]) / num(r["kernel_ms"]), k) for k, r in run.ours.items()
           if num(r.get("adjoint_ms")) and num(r.get("kernel_ms"))]
    if adj:
        slow = [x for x in adj if x[0] > 2.0]
        out.append("- The adjoint at most 2x the forward time, same method and motion (%d rows, every method, filter "
                   "and phantom): %s (ratios %.2f to %.2f)" % (
                       len(adj), "met" if not slow else "NOT met in %d: %s" % (len(slow), ", ".join(
                           "%s %d %s %s (%.2fx)" % (k[0], k[1], k[2], k[3], x) for x, k in sorted(slow)[-8:])),
                       min(x[0] for x in adj), max(x[0] for x in adj)))
    ratios = []
    for p in run.phantoms:
        for s in run.scenarios(p):
            r = run.ours[(p, s, "AB", "hardware")]
            t = run.peers.get((p, s, "torch"))
            if t and int(r["nx"]) * int(r["ny"]) * int(r["nz"]) == 256 ** 3:
                ratios.append((num(t["time_ms"]) / num(r["kernel_ms"]), p, s))
    if ratios:
        low = [x for x in ratios if x[0] < 15.0]
        out.append("- AB HARDWARE at least 15x faster than PyTorch at the same S on 256^3: %s (ratios %.1f to %.1f)" % (
            "met in all %d cases" % len(ratios) if not low else "NOT met in %d of %d: %s" % (
                len(low), len(ratios), ", ".join("%s %d (%.1fx)" % (p, s, x) for x, p, s in low)),
            min(x[0] for x in ratios), max(x[0] for x in ratios)))
    else:
        out.append("- PyTorch peer: not measured in this run")
    cpu = []
    for (p, s, m, f), r in run.pocl.items():
        sc = run.peers.get((p, s, "scipy"))
        if m == "AB" and f == "hardware" and sc:
            cpu.append((num(sc["time_ms"]) / num(r["kernel_ms"]), p, s))
    if cpu:
        low = [x for x in cpu if x[0] < 5.0]
        out.append("- AB HARDWARE through PoCL at least 5x faster than SciPy on the CPU: %s (ratios %.1f to %.1f)" % (
            "met in all %d cases" % len(cpu) if not low else "NOT met in %d of %d" % (len(low), len(cpu)),
            min(x[0] for x in cpu), max(x[0] for x in cpu)))
    else:
        out.append("- SciPy against PoCL: not measured in this run")
    if run.fetch_rate:
        out.append("- Measured: trilinear texture fetches %.0f G/s, copy bandwidth %.0f GB/s (bench/fetch_rate.cu)" % (
            run.fetch_rate, run.bandwidth or float("nan")))
    return "\n".join(out) + "\n"


def plots(run, d):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return ["Plots: not drawn (matplotlib is not installed where the report ran)."]
    made = []
    for p in run.phantoms:
        scen = run.scenarios(p)
        fig, axes = plt.subplots(2, 4, figsize=(16, 8), squeeze=False)
        for ax, s in zip(axes.ravel(), scen):
            for m, f in METHODS:
                r = run.ours.get((p, s, m, f))
                if r:
                    ax.loglog(num(r["kernel_ms"]), max(num(r["error_pct"]), 1e-6), "o" if f == "hardware" else "s",
                              color=COLOURS[m], label="%s %s" % (m, "HW" if f == "hardware" else "EX"),
                              fillstyle="full" if f == "hardware" else "none", ms=8)
            for peer, mk in (("torch", "^"), ("scipy", "v")):
                r = run.peers.get((p, s, peer))
                if r:
                    ax.loglog(num(r["time_ms"]), max(num(r["error_pct"]), 1e-6), mk, color=COLOURS[peer],
                              label={"torch": "PyTorch (GPU)", "scipy": "SciPy (CPU)"}[peer], ms=8)
            r = run.pocl.get((p, s, "AB", "hardware"))
            if r:
                ax.loglog(num(r["kernel_ms"]), max(num(r["error_pct"]), 1e-6), "D", color=COLOURS["AB"],
                          alpha=0.6, label="AB HW (PoCL, CPU)", ms=7)
            pap = run.paper.get((p, s))
            if pap:
                for m in ("CL", "RM", "AB"):
                    ax.loglog(num(pap["time_" + m.lower()]), num(pap["error_" + m.lower()]), "o", color=COLOURS[m],
                              alpha=0.25, ms=11, label="%s paper (GTX 960M)" % m)
            noise = run.get(run.ours, p, s, "REF", "exact", "error_pct")
            if noise:
                ax.axhline(noise, color="grey", ls="--", lw=1, label="REF noise")
            ax.set_title("%d: %s" % (s, motion(run.ours[(p, s, "REF", "exact")])), fontsize=10)
            ax.set_xlabel("time (ms)")
            ax.set_ylabel("error (%)")
            ax.grid(True, which="both", alpha=0.2)
        for ax in axes.ravel()[len(scen):]:
            ax.axis("off")
        handles, labels = axes.ravel()[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="lower center", ncol=6, fontsize=9)
        fig.suptitle("%s: error against time, ours (solid) and the paper's (faded)" % NAMES[p])
        fig.tight_layout(rect=(0, 0.08, 1, 0.96))
        path = os.path.join(d, "plot-%s.png" % p)
        fig.savefig(path + ".tmp.png", dpi=80)
        os.replace(path + ".tmp.png", path)
        plt.close(fig)
        made.append("![%s](plot-%s.png)" % (NAMES[p], p))
    return made


def long_csv(run, d):
    path = os.path.join(d, "paper.csv")
    with open(path + ".tmp", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["source", "phantom", "scenario", "method", "filter", "device", "error_pct", "time_ms", "e2e_ms",
                    "S", "floor_ms", "adjoint_ms"])
        for (p, s, m, fl), r in sorted(run.ours.items()):
            w.writerow(["petblur", p, s, m, fl, r["backend"] + " " + r["device"], r["error_pct"], r["kernel_ms"],
                        r["e2e_ms"], r["ab_max_slices"], fmt(run.floor_ms(p, s), 5) if m == "AB" else "",
                        r.get("adjoint_ms", "")])
        for (p, s, m, fl), r in sorted(run.pocl.items()):
            w.writerow(["petblur", p, s, m, fl, r["backend"] + " " + r["device"], r["error_pct"], r["kernel_ms"],
                        r["e2e_ms"], r["ab_max_slices"], "", r.get("adjoint_ms", "")])
        for (p, s, peer), r in sorted(run.peers.items()):
            w.writerow([peer, p, s, "classical", "trilinear", r["device"], r["error_pct"], r["time_ms"], r["e2e_ms"],
                        r["S"], "", ""])
        for (p, s), r in sorted(run.paper.items()):
            for m in ("CL", "RM", "AB"):
                w.writerow(["paper", p, s, m, "hardware", "GeForce GTX 960M", r["error_" + m.lower()],
                            r["time_" + m.lower()], "", "", "", ""])
    os.replace(path + ".tmp", path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run_dir")
    ap.add_argument("--paper", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "paper_tables.csv"))
    a = ap.parse_args()
    run = Run(a.run_dir, a.paper)
    if not run.ours:
        sys.exit("paper_report.py: %s/results.csv is missing or empty; run petblur bench --out-dir %s first"
                 % (a.run_dir, a.run_dir))
    dev = next(iter(run.ours.values()))
    parts = ["# The paper's Tables 1-3, reproduced", "",
             "petblur on %s %s, REF with %s points per voxel. The paper: GeForce GTX 960M (2016). Translations in "
             "voxels, rotations in degrees about z through the grid's centre." % (dev["backend"], dev["device"],
                                                                                dev["ref_points"]), ""]
    parts.append(targets(run))
    for p in run.phantoms:
        parts.append(phantom_tables(run, p))
    parts.append(cpu_table(run))
    parts += plots(run, a.run_dir)
    long_csv(run, a.run_dir)
    with open(os.path.join(a.run_dir, "paper.md.tmp"), "w") as f:
        f.write("\n".join(parts) + "\n")
    os.replace(os.path.join(a.run_dir, "paper.md.tmp"), os.path.join(a.run_dir, "paper.md"))
    print("\n".join(parts))


if __name__ == "__main__":
    main()

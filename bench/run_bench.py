#!/usr/bin/python3
"""trilevel benchmark: trilevel (adaptive, uniform r, uniform 2r) vs splashsurf vs OpenVDB.

    /usr/bin/python3 bench/run_bench.py [--quick] [--reps 5] [--datasets a,b] [--out bench/RESULTS.md]

Prepares the datasets (cached in ~/.cache/trilevel-bench, or $TRILEVEL_BENCH_CACHE), installs
splashsurf (pip: pysplashsurf) into a venv there, builds bench/openvdb_mesh.cpp (when
libopenvdb-dev is present) and bench/machine_flops.cpp there, runs every tool on every dataset
interleaved (warm-up round, then A B C ... A B C ... for --reps rounds), and writes
bench/RESULTS.md, bench/results.csv and bench/results.png. See bench/README.md.
Debian's python3 with numpy/scipy/matplotlib only; no third-party modules.
"""
import argparse
import csv
import datetime
import json
import math
import os
import platform
import re
import shlex
import shutil
import signal
import statistics
import subprocess
import sys
import threading
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.normpath(os.path.join(REPO, "..", "shared"))
PARTICLES_PY = os.path.join(SHARED, "tools", "particles.py")
MESHCHECK_PY = os.path.join(SHARED, "tools", "meshcheck.py")
PY = "/usr/bin/python3"
FRAME = "dam_break_frame_23_24389_particles.bgeo"

# name -> how to make it. radius = particle radius r of the file.
DATASETS = {
    "dam-break": dict(kind="generate", scene="dam-break", radius=0.025, small=True),
    "db23": dict(kind="copy", src=FRAME, radius=0.025, small=True),
    "pool-and-drop": dict(kind="generate", scene="pool-and-drop", radius=0.025, small=True),
    "db23x8": dict(kind="resample", src=FRAME, factor=8, radius=0.0125, small=False),
    "db23x64": dict(kind="resample", src=FRAME, factor=64, radius=0.00625, small=False),
    "db23x512": dict(kind="resample", src=FRAME, factor=512, radius=0.003125, small=False, huge=True),
}

# Flops per particle-pair interaction inside R in kernels/scalar_field.cl (difference 3, dot 5,
# q/k 4, grad scale 6, K 1, S 6, G 3, J rows 18 = 46) and per rejected candidate (difference +
# dot + compare ~ 9). Used only for the "how close to the machine's limit" estimate.
FLOPS_PER_INTERACTION = 46
FLOPS_PER_CANDIDATE = 9


def log(msg):
    print(f"[bench {time.strftime('%H:%M:%S')}] {msg}", flush=True)


def sh(cmd, **kw):
    log("$ " + " ".join(shlex.quote(c) for c in cmd))
    return subprocess.run(cmd, check=True, **kw)


# ---------------------------------------------------------------------------------------------
# Setup: datasets, splashsurf venv, OpenVDB harness, machine flops
# ---------------------------------------------------------------------------------------------

def prepare_dataset(name, spec, cache, trilevel):
    d = os.path.join(cache, "data")
    os.makedirs(d, exist_ok=True)
    if spec["kind"] == "generate":
        path = os.path.join(d, f"{name}_r{spec['radius']}.ply")
        if not os.path.exists(path):
            sh([trilevel, "generate", spec["scene"], "-o", path, "--radius", str(spec["radius"]), "--seed", "1"])
    elif spec["kind"] == "copy":
        path = os.path.join(d, spec["src"])
        if not os.path.exists(path):
            shutil.copyfile(os.path.join(SHARED, "data", spec["src"]), path)
    else:
        base = os.path.splitext(spec["src"])[0]
        path = os.path.join(d, f"{base}_resample{spec['factor']}.bgeo")
        if not os.path.exists(path):
            sh([PY, PARTICLES_PY, "resample", os.path.join(SHARED, "data", spec["src"]), path,
                "--factor", str(spec["factor"]), "--radius", "0.025", "--seed", "1"])
    xyz = os.path.splitext(path)[0] + ".xyz"
    if not os.path.exists(xyz):
        sh([PY, PARTICLES_PY, "convert", path, xyz], stdout=subprocess.DEVNULL)
    info_path = os.path.splitext(path)[0] + ".info.json"
    if not os.path.exists(info_path):
        out = subprocess.run([PY, PARTICLES_PY, "info", path], check=True, capture_output=True, text=True).stdout
        with open(info_path, "w") as f:
            f.write(out)
    with open(info_path) as f:
        info = json.load(f)
    return dict(name=name, path=path, xyz=xyz, radius=spec["radius"], particles=info["count"],
                spacing=info["spacing_median"], bbox=(info["bbox_min"], info["bbox_max"]))


def setup_splashsurf(cache):
    venv = os.path.join(cache, "venv")
    exe = os.path.join(venv, "bin", "pysplashsurf")
    note = ""
    try:
        if not os.path.exists(exe):
            sh([PY, "-m", "venv", venv])
            sh([os.path.join(venv, "bin", "pip"), "install", "-q", "pysplashsurf"])
        ver = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=60).stdout.strip()
        pipver = subprocess.run([os.path.join(venv, "bin", "pip"), "show", "pysplashsurf"],
                                capture_output=True, text=True).stdout
        m = re.search(r"Version: (\S+)", pipver)
        return exe, f"pysplashsurf {m.group(1) if m else '?'} ({ver})"
    except Exception as e:  # noqa: BLE001
        note = f"splashsurf unavailable: {e}"
        log(note)
        return None, note


def setup_openvdb(cache):
    exe = os.path.join(cache, "bin", "openvdb_mesh")
    src = os.path.join(REPO, "bench", "openvdb_mesh.cpp")
    if not os.path.exists("/usr/include/openvdb/openvdb.h"):
        try:
            sh(["apt-get", "install", "-y", "-q", "libopenvdb-dev"], stdout=subprocess.DEVNULL)
        except Exception as e:  # noqa: BLE001
            return None, f"libopenvdb-dev not installable: {e}"
    os.makedirs(os.path.dirname(exe), exist_ok=True)
    try:
        if not os.path.exists(exe) or os.path.getmtime(exe) < os.path.getmtime(src):
            sh(["g++", "-O2", "-std=c++17", src, "-o", exe, "-lopenvdb", "-ltbb", "-lImath-3_1"])
    except Exception as e:  # noqa: BLE001
        return None, f"openvdb_mesh build failed: {e}"
    ver = subprocess.run(["dpkg-query", "-W", "-f=${Version}", "libopenvdb-dev"], capture_output=True, text=True).stdout
    return exe, f"OpenVDB (Debian libopenvdb-dev {ver})"


def machine_flops(cache):
    exe = os.path.join(cache, "bin", "machine_flops")
    src = os.path.join(REPO, "bench", "machine_flops.cpp")
    os.makedirs(os.path.dirname(exe), exist_ok=True)
    try:
        if not os.path.exists(exe) or os.path.getmtime(exe) < os.path.getmtime(src):
            sh(["g++", "-O3", "-march=native", "-pthread", src, "-o", exe])
        out = subprocess.run([exe, "2", "0.5"], capture_output=True, text=True, check=True, timeout=120).stdout
        return json.loads(out)
    except Exception as e:  # noqa: BLE001
        log(f"machine_flops failed: {e}")
        return None


# ---------------------------------------------------------------------------------------------
# Tools
# ---------------------------------------------------------------------------------------------

def splashsurf_cmd(splashsurf, path, radius, threads, out):
    """splashsurf with the settings the comparison uses: smoothing length 2r, cube size r, iso 0.6."""
    return list(splashsurf) + ["reconstruct", path, "-r", str(radius), "-l", "2.0", "-c", "1.0", "-t", "0.6",
                               "-n", str(threads), "-q", "-o", out]


def make_tools(args, trilevel, splashsurf, openvdb):
    tools = []

    def tri(name, extra):
        def cmd(ds, out, stats):
            return [trilevel, "reconstruct", ds["path"], "-r", str(ds["radius"]), "-o", out, "--stats", stats] + extra
        tools.append(dict(name=name, cmd=cmd, kind="trilevel"))

    tri("trilevel-adaptive", [])
    # Levels from curvature alone, as before the level-2 check was on by default (docs/calibration.md, "Levels
    # and choosing the threshold"): what the check buys, measured in the same run.
    tri("trilevel-adaptive-curvature", ["--level2-tolerance", "0", "--curvature-threshold", "4.5"])
    tri("trilevel-uniform1", ["--mode", "uniform", "--cell", "1"])
    tri("trilevel-uniform2", ["--mode", "uniform", "--cell", "2"])
    if splashsurf:
        tools.append(dict(name="splashsurf", kind="splashsurf", cmd=lambda ds, out, stats: splashsurf_cmd(
            [splashsurf], ds["path"], ds["radius"], 2, out)))
    if openvdb:
        for name, rad, ada, ero in (("openvdb-a0", 1.0, 0.0, 0.0), ("openvdb-a0.5", 1.0, 0.5, 0.0),
                                    ("openvdb-2r-erode", 2.0, 0.0, 1.0)):
            if args.no_vdb_closing and ero:
                continue

            limit = args.vdb_closing_max_particles if ero else None

            def cmd(ds, out, stats, rad=rad, ada=ada, ero=ero):
                r = ds["radius"]
                c = [openvdb, ds["xyz"], out, "--radius", repr(rad * r), "--voxel", repr(r),
                     "--adaptivity", str(ada), "--threads", "2"]
                if ero:
                    c += ["--erode", repr(ero * r)]
                return c
            tools.append(dict(name=name, kind="openvdb", cmd=cmd, max_particles=limit))
    if args.tools:
        keep = set(args.tools.split(","))
        tools = [t for t in tools if t["name"] in keep]
    return tools


def run_timed(cmd, timeout, stdout_path, stderr_path, env=None):
    """Wall time (s), peak RSS (bytes) of the child via wait4, exit code (None on timeout)."""
    with open(stdout_path, "wb") as so, open(stderr_path, "wb") as se:
        t0 = time.perf_counter()
        p = subprocess.Popen(cmd, stdout=so, stderr=se, env=env, start_new_session=True)
        timed_out = []

        def kill():
            timed_out.append(True)
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        timer = threading.Timer(timeout, kill)
        timer.start()
        _, status, ru = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t0
        timer.cancel()
        p.returncode = os.waitstatus_to_exitcode(status)
    return wall, ru.ru_maxrss * 1024, (None if timed_out else p.returncode)


def ply_counts(path):
    """(vertices, faces) from a PLY header."""
    nv = nf = None
    with open(path, "rb") as f:
        for _ in range(200):
            line = f.readline()
            if not line:
                break
            parts = line.decode("ascii", "replace").split()
            if parts[:2] == ["element", "vertex"]:
                nv = int(parts[2])
            elif parts[:2] == ["element", "face"]:
                nf = int(parts[2])
            elif parts and parts[0] == "end_header":
                break
    return nv, nf


def flatten_stats(st):
    row = {}
    for k, v in st.get("time_ms", {}).items():
        row[f"stage_ms.{k}"] = v
    for k, v in st.get("kernel_ms", {}).items():
        row[f"kernel_ms.{k}"] = v
    for k in ("fine_points", "surface_cells", "triangles", "peak_memory_bytes", "surface_particles"):
        if k in st:
            row[f"stats.{k}"] = st[k]
    for k, v in st.get("triangles_by_kind", {}).items():
        row[f"stats.triangles_{k}"] = v
    for k, v in st.get("fine_points_by_level", {}).items():
        row[f"stats.fine_points_l{k}"] = v
    return row


# ---------------------------------------------------------------------------------------------
# Main loop
# ---------------------------------------------------------------------------------------------

def bench_dataset(ds, tools, args, workdir, env):
    rows = []
    outputs = {}
    dead = set()
    for rep in range(-1, args.reps):  # -1 = warm-up (kernel cache, page cache), not recorded
        for t in tools:
            if t["name"] in dead or (t.get("max_particles") and ds["particles"] > t["max_particles"]):
                continue
            out = os.path.join(workdir, f"{ds['name']}.{t['name']}.ply")
            stats = os.path.join(workdir, f"{ds['name']}.{t['name']}.stats.json")
            if os.path.exists(stats):
                os.remove(stats)
            cmd = t["cmd"](ds, out, stats)
            so = os.path.join(workdir, f"{ds['name']}.{t['name']}.stdout")
            se = os.path.join(workdir, f"{ds['name']}.{t['name']}.stderr")
            wall, rss, rc = run_timed(cmd, args.timeout, so, se, env)
            status = "ok" if rc == 0 else ("timeout" if rc is None else f"exit {rc}")
            row = dict(dataset=ds["name"], particles=ds["particles"], radius=ds["radius"], tool=t["name"],
                       rep=rep, wall_s=round(wall, 4), peak_rss_mb=round(rss / 2**20, 1), status=status)
            if status == "ok":
                row["vertices"], row["triangles"] = ply_counts(out)
                if t["kind"] == "trilevel" and os.path.exists(stats):
                    with open(stats) as f:
                        row.update(flatten_stats(json.load(f)))
                if t["kind"] == "openvdb":
                    try:
                        with open(so) as f:
                            vj = json.loads(f.read().strip().splitlines()[-1])
                        for k, v in vj["time_ms"].items():
                            row[f"stage_ms.{k}"] = v
                    except Exception:  # noqa: BLE001
                        pass
                outputs[t["name"]] = out
            else:
                try:
                    with open(se, errors="replace") as f:
                        row["error"] = " ".join(f.read().strip().splitlines()[-2:])[-300:]
                except OSError:
                    pass
                dead.add(t["name"])
                outputs.pop(t["name"], None)
            log(f"{ds['name']:>14} {t['name']:<18} rep {rep:>2}: {wall:8.3f} s {rss / 2**20:8.1f} MB "
                f"{row.get('triangles', '-')!s:>9} tris  {status}")
            if rep >= 0 or status != "ok":
                rows.append(row)
    # Mesh checks on the last outputs (all runs of a tool are deterministic or near enough).
    checks = {}
    for name, out in outputs.items():
        if args.no_check:
            break
        try:
            p = subprocess.run([PY, MESHCHECK_PY, "check", out, "--closed", "--by-index"], capture_output=True,
                               text=True, timeout=args.check_timeout)
            checks[name] = dict(closed=(p.returncode == 0), msg=(p.stdout + p.stderr).strip().splitlines()[-1:])
        except subprocess.TimeoutExpired:
            checks[name] = dict(closed=None, msg=["check timed out"])
        log(f"{ds['name']} {name}: closed={checks[name]['closed']} {checks[name]['msg']}")
    compare = {}
    b = outputs.get("trilevel-uniform1")
    for tool in ("trilevel-adaptive", "trilevel-adaptive-curvature"):
        a = outputs.get(tool)
        if not (a and b) or args.no_compare:
            continue
        try:
            p = subprocess.run([PY, MESHCHECK_PY, "compare", a, b, "--unit", str(ds["radius"]), "--samples",
                                str(args.samples), "--json"], capture_output=True, text=True, timeout=args.check_timeout)
            compare[tool] = json.loads(p.stdout) if p.returncode == 0 else {"error": p.stderr.strip()[-300:]}
        except subprocess.TimeoutExpired:
            compare[tool] = {"error": "compare timed out"}
        except json.JSONDecodeError as e:
            compare[tool] = {"error": f"bad JSON: {e}"}
        log(f"{ds['name']} compare {tool} vs uniform1: {json.dumps(compare[tool])[:300]}")
    return rows, checks, compare


# ---------------------------------------------------------------------------------------------
# Report
# ---------------------------------------------------------------------------------------------

def med(xs):
    xs = [x for x in xs if x is not None]
    return statistics.median(xs) if xs else None


def fmt(x, nd=3):
    if x is None:
        return "–"
    if isinstance(x, float):
        if x != 0 and abs(x) < 10 ** -nd:
            return f"{x:.2g}"
        return f"{x:.{nd}f}"
    return str(x)


def fmt_int(x):
    return "–" if x is None else f"{int(x):,}"


def ratio(a, b):
    return None if a is None or b in (None, 0) else a / b


def summarize(rows):
    """(dataset, tool) -> dict of medians."""
    agg = {}
    for r in rows:
        key = (r["dataset"], r["tool"])
        a = agg.setdefault(key, dict(walls=[], rss=[], rows=[], status=set()))
        a["status"].add(r["status"])
        if r["status"] == "ok" and r["rep"] >= 0:
            a["walls"].append(r["wall_s"])
            a["rss"].append(r["peak_rss_mb"])
            a["rows"].append(r)
    out = {}
    for key, a in agg.items():
        rs = a["rows"]
        s = dict(n=len(rs), wall_min=min(a["walls"]) if a["walls"] else None, wall_med=med(a["walls"]),
                 rss_med=med(a["rss"]), triangles=med([r.get("triangles") for r in rs]),
                 status=",".join(sorted(a["status"])))
        keys = set()
        for r in rs:
            keys.update(k for k in r if k.startswith(("stage_ms.", "kernel_ms.", "stats.")))
        for k in keys:
            s[k] = med([r.get(k) for r in rs])
        out[key] = s
    return out


def write_csv(rows, path):
    keys = []
    for r in rows:
        for k in r:
            if k not in keys:
                keys.append(k)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow(r)


def write_plot(summary, datasets, tools, path):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        log("matplotlib missing (apt-get install -y python3-matplotlib): no plot")
        return False
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    for t in tools:
        pts = []
        for ds in datasets:
            s = summary.get((ds["name"], t["name"]))
            if s and s["wall_med"] is not None:
                pts.append((ds["particles"], s["wall_med"], s["triangles"], ds["name"]))
        if not pts:
            continue
        pts.sort()
        style = "-o" if t["kind"] == "trilevel" else ("--s" if t["kind"] == "splashsurf" else ":^")
        axes[0].plot([p[0] for p in pts], [p[1] for p in pts], style, label=t["name"])
        axes[1].plot([p[0] for p in pts], [p[2] for p in pts], style, label=t["name"])
    for ax, yl in zip(axes, ("median wall time [s] (read + reconstruct + write)", "triangles")):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("particles")
        ax.set_ylabel(yl)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle("trilevel vs splashsurf vs OpenVDB (2 threads, medians of interleaved runs)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return True


def neighbour_estimate(ds, kernel_radius_r=4.0):
    """Mean particles within R and candidate particles in the 27 bins of a fine point, assuming a
    simple-cubic number density 1/s^3 from the median nearest-neighbour spacing s, and half of the
    neighbourhood inside the fluid (fine points lie in a band around the surface)."""
    R = kernel_radius_r * ds["radius"]
    n = 1.0 / ds["spacing"] ** 3
    inside = 0.5
    interactions = 4.0 / 3.0 * math.pi * R ** 3 * n * inside
    candidates = 27.0 * R ** 3 * n * inside
    return interactions, candidates


def write_report(path, args, datasets, tools, rows, summary, checks, compares, meta):
    L = []
    add = L.append
    add("# trilevel benchmark results")
    add("")
    add(f"Generated by `{meta['command']}` on {meta['date']}.")
    add("")
    add(f"- trilevel: `{meta['trilevel']}` built from git `{meta['git']}`")
    add(f"- machine: {meta['cpu']}, {meta['nproc']} cores, {meta['mem_gb']:.0f} GiB RAM, {meta['os']}")
    add(f"- machine float throughput (bench/machine_flops.cpp, FP32 FMA, per CPU second of each thread, best of 3): "
        + (f"**{meta['flops']['gflops']:.0f} GFLOP/s with 2 threads**, {meta['flops']['gflops_1thread']:.0f} GFLOP/s with 1"
           + (f" ({meta['flops']['wall_gflops']:.0f} GFLOP/s by wall time: what the shared cores gave)"
              if "wall_gflops" in meta["flops"] else "")
           if meta["flops"] else "not measured"))
    if meta.get("loadavg_start"):
        la = meta["loadavg_start"]
        lb = meta.get("loadavg_end")
        add(f"- load average (1/5/15 min) at start: {la[0]:.2f} / {la[1]:.2f} / {la[2]:.2f}"
            + (f", at end: {lb[0]:.2f} / {lb[1]:.2f} / {lb[2]:.2f}" if lb else "")
            + " (other jobs share the 2 cores; the FLOPS figure is the better of a probe at start and end)")
    add(f"- splashsurf: {meta['splashsurf']}; `pysplashsurf reconstruct IN -r R -l 2.0 -c 1.0 -t 0.6 -n 2 -q -o OUT.ply`")
    add(f"- OpenVDB: {meta['openvdb']}; `bench/openvdb_mesh.cpp`: ParticlesToLevelSet (voxel = r, rMin 0.5 voxel) + "
        "volumeToMesh, 2 TBB threads; `openvdb-a0`: spheres of radius r, adaptivity 0; `openvdb-a0.5`: same, adaptivity 0.5; "
        "`openvdb-2r-erode`: spheres of 2r, levelSetRebuild, then LevelSetFilter::offset(r) (erosion by r: a closing of "
        "the r-spheres, the variant whose surface matches the others), adaptivity 0, only up to "
        f"{args.vdb_closing_max_particles:,} particles. Faces rewound outward. Reads raw .xyz "
        "(the other tools read the same particles as PLY/BGEO).")
    add(f"- {args.reps} timed repetitions per tool after one warm-up run, interleaved (A B C … A B C …); "
        f"per-run timeout {args.timeout:.0f} s. Wall time includes process start, file read and write. "
        "Peak memory = max RSS of the process (wait4). All tools at 2 threads on a 2-core machine shared with other "
        "jobs: medians are the numbers to read, min shows the noise floor.")
    add("")
    # Targets summary
    add("## Targets (docs/design.md §10)")
    add("")
    add("| target | dataset | measured | goal | status |")
    add("| --- | --- | --- | --- | --- |")

    def target(label, dsn, val, goal, le=True):
        if val is None:
            add(f"| {label} | {dsn} | – | {goal} | not measured |")
            return
        ok = val <= goal if le else val >= goal
        add(f"| {label} | {dsn} | {val:.3f} | ≤ {goal} | {'met' if ok else '**missed**'} |")

    names = [d["name"] for d in datasets]
    for dsn in names:
        A = summary.get((dsn, "trilevel-adaptive"))
        S = summary.get((dsn, "splashsurf"))
        U = summary.get((dsn, "trilevel-uniform1"))
        if not A:
            continue
        if dsn in ("db23x64", "db23x512", "db23x8"):
            if S:
                target("adaptive / splashsurf wall time", dsn, ratio(A["wall_med"], S["wall_med"]), 0.5)
                target("adaptive / splashsurf triangles", dsn, ratio(A["triangles"], S["triangles"]), 0.35)
                target("adaptive / splashsurf peak memory", dsn, ratio(A["rss_med"], S["rss_med"]), 0.5)
            if U:
                target("adaptive / uniform r wall time", dsn, ratio(A["wall_med"], U["wall_med"]), 0.5)
                target("adaptive / uniform r peak memory", dsn, ratio(A["rss_med"], U["rss_med"]), 0.35)
        for tool, tag in (("trilevel-adaptive", ""), ("trilevel-adaptive-curvature", ", curvature only")):
            T = summary.get((dsn, tool))
            if dsn not in ("db23", "db23x8", "pool-and-drop") or not U or not T:
                continue
            target(f"adaptive{tag} / uniform r triangles", dsn, ratio(T["triangles"], U["triangles"]), 0.40)
            target(f"adaptive{tag} / uniform r peak memory", dsn, ratio(T["rss_med"], U["rss_med"]), 1.0)
            target(f"adaptive{tag} / uniform r wall time", dsn, ratio(T["wall_med"], U["wall_med"]), 1.0)
            c = compares.get(dsn, {}).get(tool)
            if c and "symmetric" in c:
                target(f"deviation{tag} mean vs uniform r [r]", dsn, c["symmetric"].get("mean"), 0.1)
                target(f"deviation{tag} p99 vs uniform r [r]", dsn, c["symmetric"].get("p99"), 0.5)
            pt = T.get("stats.triangles_patch")
            if pt is not None and T["triangles"]:
                target(f"patch triangles{tag} / all", dsn, pt / T["triangles"], 0.01)
        if dsn == "db23":
            target("24 k frame, warm start, wall [s]", dsn, A["wall_med"], 0.3)
    add("")
    # Per-dataset tables
    add("## Per dataset")
    for ds in datasets:
        dsn = ds["name"]
        add("")
        add(f"### {dsn}: {ds['particles']:,} particles, r = {ds['radius']}")
        add("")
        add("| tool | wall min [s] | wall median [s] | peak memory [MB] | triangles | closed (by index) | runs |")
        add("| --- | ---: | ---: | ---: | ---: | --- | --- |")
        for t in tools:
            s = summary.get((dsn, t["name"]))
            if not s:
                continue
            ck = checks.get(dsn, {}).get(t["name"])
            closed = "–" if not ck else ("yes" if ck["closed"] else ("?" if ck["closed"] is None else "**no**"))
            add(f"| {t['name']} | {fmt(s['wall_min'])} | {fmt(s['wall_med'])} | {fmt(s['rss_med'], 0)} | "
                f"{fmt_int(s['triangles'])} | {closed} | {s['n']} {s['status']} |")
    # Ratios vs peers
    add("")
    add("## trilevel adaptive vs peers (ratios of medians; < 1 = trilevel better)")
    add("")
    peers = [t["name"] for t in tools if t["kind"] != "trilevel"]
    add("| dataset | peer | time ratio | triangle ratio | memory ratio |")
    add("| --- | --- | ---: | ---: | ---: |")
    for ds in datasets:
        A = summary.get((ds["name"], "trilevel-adaptive"))
        if not A:
            continue
        for p in peers:
            P = summary.get((ds["name"], p))
            if not P:
                continue
            add(f"| {ds['name']} | {p} | {fmt(ratio(A['wall_med'], P['wall_med']), 2)} | "
                f"{fmt(ratio(A['triangles'], P['triangles']), 2)} | {fmt(ratio(A['rss_med'], P['rss_med']), 2)} |")
    # Table 2
    add("")
    add("## Table 2 (as in the paper): uniform 2r, adaptive, uniform r")
    add("")
    add("Medians; ratios are to uniform r on the same dataset in the same run. Deviation: "
        "`meshcheck.py compare adaptive uniform1 --unit r` (symmetric, pooled samples).")
    add("")
    add("| dataset | mode | time [s] | × | triangles | × | memory [MB] | × | patch tris | deviation mean / p99 [r] |")
    add("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |")
    for ds in datasets:
        U = summary.get((ds["name"], "trilevel-uniform1"))
        for mode, tname in (("uniform 2r", "trilevel-uniform2"), ("adaptive", "trilevel-adaptive"),
                            ("adaptive, curvature only", "trilevel-adaptive-curvature"), ("uniform r", "trilevel-uniform1")):
            s = summary.get((ds["name"], tname))
            if not s:
                continue
            dev = ""
            if tname.startswith("trilevel-adaptive"):
                c = compares.get(ds["name"], {}).get(tname)
                if c and "symmetric" in c:
                    dev = f"{c['symmetric']['mean']:.3f} / {c['symmetric']['p99']:.3f}"
                elif c:
                    dev = c.get("error", "")[:60]
            pt = s.get("stats.triangles_patch")
            add(f"| {ds['name']} | {mode} | {fmt(s['wall_med'])} | {fmt(ratio(s['wall_med'], U and U['wall_med']), 2)} | "
                f"{fmt_int(s['triangles'])} | {fmt(ratio(s['triangles'], U and U['triangles']), 2)} | "
                f"{fmt(s['rss_med'], 0)} | {fmt(ratio(s['rss_med'], U and U['rss_med']), 2)} | "
                f"{fmt_int(pt) if pt is not None else '–'} | {dev} |")
    # Stage times
    add("")
    add("## trilevel time per stage (medians of `--stats` `time_ms`, ms)")
    add("")
    tri_keys = []
    for (dsn, tn), s in summary.items():
        if tn.startswith("trilevel"):
            for k in s:
                if k.startswith("stage_ms.") and k not in tri_keys:
                    tri_keys.append(k)
    order = ["read", "binning", "surface_particles", "surface_cells", "scalar_field", "band_closure",
             "edge_refinement", "triangulation", "write"]
    rank = {f"stage_ms.{k}": i for i, k in enumerate(order)}
    tri_keys = sorted((k for k in tri_keys if not k.endswith(".total")), key=lambda k: (rank.get(k, 50), k)) + \
        [k for k in tri_keys if k.endswith(".total")]
    add("| dataset | mode | " + " | ".join(k.split(".", 1)[1] for k in tri_keys) + " | wall | wall − total |")
    add("| --- | --- | " + " | ".join("---:" for _ in tri_keys) + " | ---: | ---: |")
    for ds in datasets:
        for t in tools:
            if t["kind"] != "trilevel":
                continue
            s = summary.get((ds["name"], t["name"]))
            if not s or s["wall_med"] is None:
                continue
            tot = s.get("stage_ms.total")
            add(f"| {ds['name']} | {t['name'][len('trilevel-'):]} | " + " | ".join(fmt(s.get(k), 1) for k in tri_keys)
                + f" | {s['wall_med'] * 1000:.1f} | {fmt(s['wall_med'] * 1000 - tot, 1) if tot is not None else '–'} |")
    add("")
    add("`wall − total`: process start, OpenCL platform/context setup, program build or cache load, and what the "
        "stats do not time (e.g. reading/writing if outside `total`).")
    # Scalar-field kernel vs machine
    add("")
    add("## Scalar-field kernel vs the machine's limit")
    add("")
    gf = meta["flops"]["gflops"] if meta["flops"] else None
    add("Fine points/s = `fine_points` / (`kernel_ms.scalar_field_cells` + `kernel_ms.scalar_field`). Interactions (particles within R = 4r) per "
        "point are estimated as ½ · 4/3 π R³ / s³ (s = median nearest-neighbour spacing of the input, simple-cubic "
        "density, half the neighbourhood inside the fluid for points in the surface band), candidates tested as "
        f"½ · 27 R³ / s³ (27 bins of size R). Flops: {FLOPS_PER_INTERACTION} per interaction, "
        f"{FLOPS_PER_CANDIDATE} per candidate (counted from kernels/scalar_field.cl). Estimates, not counters.")
    add("")
    add("| dataset | mode | fine points | kernel [ms] | points/s | est. interactions/point | est. interactions/s | "
        "est. GFLOP/s | % of machine FP32 peak |")
    add("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for ds in datasets:
        inter, cand = neighbour_estimate(ds)
        for t in tools:
            if t["kind"] != "trilevel":
                continue
            s = summary.get((ds["name"], t["name"]))
            if not s:
                continue
            fp = s.get("stats.fine_points")
            # the scalar field runs as the per-cell kernel, plus the per-point one for what it leaves
            km = (s.get("kernel_ms.scalar_field") or 0) + (s.get("kernel_ms.scalar_field_cells") or 0)
            if not fp or not km:
                continue
            pps = fp / (km / 1000.0)
            ips = pps * inter
            gfl = pps * (inter * FLOPS_PER_INTERACTION + cand * FLOPS_PER_CANDIDATE) * 1e-9
            add(f"| {ds['name']} | {t['name'][len('trilevel-'):]} | {fmt_int(fp)} | {km:.1f} | {pps / 1e6:.2f} M | "
                f"{inter:.1f} | {ips / 1e6:.0f} M | {gfl:.1f} | {fmt(ratio(gfl, gf) * 100 if gf else None, 1)} % |")
    add("")
    if meta.get("notes"):
        add("## Notes")
        add("")
        for n in meta["notes"]:
            add(f"- {n}")
        add("")
    add("Raw data: `bench/results.csv` (one row per dataset × tool × repetition, failures included); plot: "
        "`bench/results.png`.")
    with open(path, "w") as f:
        f.write("\n".join(L) + "\n")


def machine_meta():
    cpu = "?"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem = 0
    try:
        with open("/proc/meminfo") as f:
            mem = int(f.readline().split()[1]) / 2**20
    except OSError:
        pass
    return cpu, os.cpu_count(), mem


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="small datasets only, 3 repetitions (smoke test)")
    ap.add_argument("--reps", type=int, default=None, help="timed repetitions per tool (default 5, --quick 3)")
    ap.add_argument("--datasets", default=None, help="comma list from: " + ",".join(DATASETS))
    ap.add_argument("--x512", action="store_true", help="also the ×512 resampling (17.7 M particles)")
    ap.add_argument("--tools", default=None, help="comma list of tool names to run (default all)")
    ap.add_argument("--out", default=os.path.join(REPO, "bench", "RESULTS.md"))
    ap.add_argument("--csv", default=None, help="default: results.csv next to --out")
    ap.add_argument("--png", default=None, help="default: results.png next to --out")
    ap.add_argument("--trilevel", default=os.path.join(REPO, "build", "bin", "trilevel"))
    ap.add_argument("--cache", default=os.environ.get("TRILEVEL_BENCH_CACHE",
                                                      os.path.expanduser("~/.cache/trilevel-bench")))
    ap.add_argument("--timeout", type=float, default=600.0, help="per run, seconds")
    ap.add_argument("--check-timeout", type=float, default=900.0, help="per meshcheck call, seconds")
    ap.add_argument("--samples", type=int, default=100000, help="meshcheck compare samples")
    ap.add_argument("--no-check", action="store_true", help="skip meshcheck check --closed")
    ap.add_argument("--no-compare", action="store_true", help="skip meshcheck compare")
    ap.add_argument("--no-vdb-closing", action="store_true", help="skip the openvdb-2r-erode variant")
    ap.add_argument("--vdb-closing-max-particles", type=int, default=300000,
                    help="run openvdb-2r-erode only up to this many particles (its level-set rebuild and "
                         "offset are slow; default 300000)")
    ap.add_argument("--no-splashsurf", action="store_true")
    ap.add_argument("--no-openvdb", action="store_true")
    ap.add_argument("--report-only", metavar="STATE.json", default=None,
                    help="re-render RESULTS.md/CSV/PNG from a saved run (results.json, written next to the CSV), run nothing")
    args = ap.parse_args()
    if args.report_only:
        with open(args.report_only) as f:
            st = json.load(f)
        out_dir = os.path.dirname(os.path.abspath(args.out))
        args.csv = args.csv or os.path.join(out_dir, "results.csv")
        args.png = args.png or os.path.join(out_dir, "results.png")
        args.reps, args.timeout = st["reps"], st["timeout"]
        args.vdb_closing_max_particles = st["vdb_closing_max_particles"]
        summary = summarize(st["rows"])
        write_csv(st["rows"], args.csv)
        write_report(args.out, args, st["datasets"], st["tools"], st["rows"], summary, st["checks"],
                     st["compares"], st["meta"])
        write_plot(summary, st["datasets"], st["tools"], args.png)
        log(f"wrote {args.out}, {args.csv}, {args.png} from {args.report_only}")
        return
    if args.reps is None:
        args.reps = 3 if args.quick else 5
    out_dir = os.path.dirname(os.path.abspath(args.out))
    args.csv = args.csv or os.path.join(out_dir, "results.csv")
    args.png = args.png or os.path.join(out_dir, "results.png")
    args.state = os.path.splitext(args.csv)[0] + ".json"
    for pth in (args.out, args.csv, args.png):
        os.makedirs(os.path.dirname(os.path.abspath(pth)), exist_ok=True)
    trilevel = os.path.abspath(args.trilevel)
    if not os.access(trilevel, os.X_OK):
        sys.exit(f"run_bench: error: {trilevel} not found; build it (cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "
                 "&& cmake --build build -j2) or pass --trilevel")
    if not os.path.exists(PARTICLES_PY):
        sys.exit(f"run_bench: error: {PARTICLES_PY} not found (../shared next to the repository)")
    os.makedirs(args.cache, exist_ok=True)

    if args.datasets:
        names = args.datasets.split(",")
        for n in names:
            if n not in DATASETS:
                sys.exit(f"run_bench: error: unknown dataset {n} (known: {','.join(DATASETS)})")
    elif args.quick:
        names = [n for n, s in DATASETS.items() if s["small"]]
    else:
        names = [n for n, s in DATASETS.items() if not s.get("huge") or args.x512]
    notes = []
    log("preparing datasets")
    datasets = [prepare_dataset(n, DATASETS[n], args.cache, trilevel) for n in names]
    datasets.sort(key=lambda d: d["particles"])
    splashsurf, ss_note = (None, "disabled (--no-splashsurf)") if args.no_splashsurf else setup_splashsurf(args.cache)
    openvdb, vdb_note = (None, "disabled (--no-openvdb)") if args.no_openvdb else setup_openvdb(args.cache)
    if not splashsurf:
        notes.append(f"splashsurf not run: {ss_note}")
    if not openvdb:
        notes.append(f"OpenVDB not run: {vdb_note}")
    flops = machine_flops(args.cache)
    log(f"machine flops: {flops}")
    tools = make_tools(args, trilevel, splashsurf, openvdb)
    workdir = os.path.join(args.cache, "runs")
    os.makedirs(workdir, exist_ok=True)
    env = dict(os.environ)
    env.setdefault("POCL_MAX_PTHREAD_COUNT", "2")
    env.setdefault("POCL_CPU_MAX_CU_NUM", "2")
    env.setdefault("RAYON_NUM_THREADS", "2")

    git = "?"
    try:
        h = subprocess.run(["git", "-C", REPO, "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", REPO, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True).stdout.strip()
        git = h + (" + uncommitted changes in the working tree" if dirty else "")
    except OSError:
        pass
    cpu, nproc, mem = machine_meta()
    meta = dict(command="/usr/bin/python3 bench/run_bench.py " + " ".join(shlex.quote(a) for a in sys.argv[1:]),
                date=datetime.datetime.now().strftime("%Y-%m-%d %H:%M"), trilevel=os.path.relpath(trilevel, REPO),
                git=git, cpu=cpu, nproc=nproc, mem_gb=mem, os=platform.platform(), flops=flops,
                splashsurf=ss_note, openvdb=vdb_note, notes=notes, loadavg_start=os.getloadavg())

    all_rows, checks, compares = [], {}, {}
    for ds in datasets:
        log(f"=== {ds['name']} ({ds['particles']:,} particles, r = {ds['radius']}) ===")
        rows, ck, cmp = bench_dataset(ds, tools, args, workdir, env)
        all_rows += rows
        checks[ds["name"]] = ck
        if cmp:
            compares[ds["name"]] = cmp
        # Write after every dataset, so a cut-off run still leaves its results.
        with open(args.state, "w") as f:
            json.dump(dict(rows=all_rows, checks=checks, compares=compares, meta=meta, datasets=datasets,
                           tools=[dict(name=t["name"], kind=t["kind"]) for t in tools], reps=args.reps,
                           timeout=args.timeout, vdb_closing_max_particles=args.vdb_closing_max_particles), f)
        summary = summarize(all_rows)
        write_csv(all_rows, args.csv)
        write_report(args.out, args, datasets, tools, all_rows, summary, checks, compares, meta)
        write_plot(summary, datasets, tools, args.png)
    # The FLOPS probe competes with whatever else runs on the machine: measure again at the end and
    # keep the better figure (load only ever lowers it).
    flops2 = machine_flops(args.cache)
    if flops2 and (not meta["flops"] or flops2["gflops"] > meta["flops"]["gflops"]):
        meta["flops"] = flops2
    meta["loadavg_end"] = os.getloadavg()
    with open(args.state, "w") as f:
        json.dump(dict(rows=all_rows, checks=checks, compares=compares, meta=meta, datasets=datasets,
                       tools=[dict(name=t["name"], kind=t["kind"]) for t in tools], reps=args.reps,
                       timeout=args.timeout, vdb_closing_max_particles=args.vdb_closing_max_particles), f)
    write_report(args.out, args, datasets, tools, all_rows, summarize(all_rows), checks, compares, meta)
    log(f"wrote {args.out}, {args.csv}, {args.png}")


if __name__ == "__main__":
    main()

//! G-code import at scale (issue 26, item 7): a CAM-style file of about
//! 500 000 lines (16 MB) read, interpreted, checked and converted, stage by
//! stage and as `gcode::import`, against CNCjs's `gcode-toolpath` (Node) on
//! the same file in the same run; and the peak memory at three sizes.
//!
//! Run: `cargo bench --bench gcode` (optimised build). Options:
//! `--lines N` (default 500 000), `--runs N` (best of N, default 5),
//! `--no-node` (skip CNCjs), `--write FILE` (write the generated file and
//! stop; `jogterm import FILE` reads it with the offsets below set),
//! `--profile STAGE` (run only `read`, `interpret`, `check`, `isel` or
//! `import`, `--runs` times, under a profiler). Results:
//! `docs/gcode.md`, "Performance".
//!
//! - The file is generated deterministically (a fixed-seed generator): a
//!   Fusion 360 grbl-post header; 3D finishing passes with X Y Z on every
//!   line (most of the lines, as in big CAM files); 2D contours of many
//!   short `G1` segments and `G2`/`G3` arcs (I J and R, some of them tiny)
//!   with helical ramps; drilling cycles; comments; `N` numbers on some
//!   lines, lower case without blanks (`g1x1.234y5.678`) on others. In work
//!   coordinates it spans X -120..120, Y -80..80, Z -10..15 mm; the bench
//!   sets G54's zero at machine X 150, Y 100, Z 50 mm so that the default
//!   profile's soft limits (X 0..300, Y 0..200, Z 0..80) hold it.
//! - Times are the best of `--runs` runs of the real functions on the real
//!   file: `reader::read`, `interpret` (which reads too: the interpreter
//!   alone is the difference), `check_limits` + `summarise`,
//!   `isel::convert` and `emcu::convert`, and `import` (all of it, to isel).
//!   CPU is the process's, all threads: a file of 1 MiB or more is read
//!   ahead on a second thread, and a long job's isel conversion is cut in
//!   two, so wall time is less than CPU time there (CNCjs's CPU is its
//!   process's too, its garbage collector's threads with it).
//! - Memory: each size runs `import` once in a child process of this bench
//!   (a fresh heap): the peak of live heap bytes counted by a global
//!   allocator in this bench (the import's own, the file's text excluded),
//!   and the peak resident set (`VmHWM` from `/proc/self/status`, reset
//!   through `/proc/self/clear_refs` after the file is generated, so it is
//!   the import's peak with the text and the runtime in it).
//! - CNCjs: `npm install gcode-toolpath` into `target/gcode-bench-node`
//!   (never committed) when it is not there, a script written there that
//!   times `new Toolpath({addLine, addArcCurve}).loadFromStringSync(text)`
//!   best of the same runs in one Node process (its JIT warmed as ours is
//!   cached). No node or npm, or no network: the row says so and is
//!   skipped.
//!
//! Hand-written, not on divan: one 16 MB file run a few times per stage
//! (best of N), beside CNCjs in a Node process, and peak memory measured in
//! child processes with a fresh heap; a harness that repeats a closure
//! many times fits none of the three.

// A benchmark's setup that fails cannot measure anything: it stops with its
// message (Cargo.toml [lints] denies these in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

#[path = "support/cam.rs"]
mod cam;
mod support;

use std::alloc::{GlobalAlloc, Layout, System as SystemAlloc};
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use cam::{ZERO_MM, cam_file, fnv, machine};
use jogterm::config::Profile;
use jogterm::gcode::check::{check_limits, summarise};
use jogterm::gcode::output::Header;
use jogterm::gcode::profile::{machine_of, setup_of};
use jogterm::gcode::{Target, emcu, import, interpret, isel, reader};
use jogterm::offsets::{System, WorkOffsets};

/// Counts live heap bytes and their peak: two relaxed atomic operations per
/// allocation, the same for every stage, so the times stay comparable.
struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

// SAFETY: every call forwards to the system allocator unchanged; only the
// counters are added.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's layout, forwarded.
        let p = unsafe { SystemAlloc.alloc(layout) };
        if !p.is_null() {
            grow(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's pointer and layout, forwarded.
        unsafe { SystemAlloc.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: the caller's pointer, layout and size, forwarded.
        let p = unsafe { SystemAlloc.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
            grow(new_size);
        }
        p
    }
}

fn grow(size: usize) {
    let live = LIVE.fetch_add(size, Ordering::Relaxed) + size;
    if live > PEAK.load(Ordering::Relaxed) {
        PEAK.store(live, Ordering::Relaxed);
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Best of `runs`: the shortest wall time, the shortest CPU time of the
/// process (all threads: a long file's import reads ahead and converts on
/// two), and the last result (dropped outside the timing).
struct Best<T> {
    wall: Duration,
    cpu: Duration,
    out: T,
}

fn best<T>(runs: usize, mut f: impl FnMut() -> T) -> Best<T> {
    let (mut wall, mut cpu) = (Duration::MAX, Duration::MAX);
    let mut last = None;
    for _ in 0..runs {
        drop(last.take());
        let (start, start_cpu) = (Instant::now(), process_cpu());
        let out = black_box(f());
        wall = wall.min(start.elapsed());
        cpu = cpu.min(process_cpu().saturating_sub(start_cpu));
        last = Some(out);
    }
    Best {
        wall,
        cpu,
        out: last.expect("at least one run"),
    }
}

/// User and system CPU of the process so far, all its threads.
fn process_cpu() -> Duration {
    let (user, system, _) = support::process_cpu();
    user + system
}

fn arg(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1).cloned())
}

fn flag(name: &str) -> bool {
    std::env::args().any(|a| a == name)
}

const MIB: f64 = 1024.0 * 1024.0;

/// In the child process: one import of `lines` lines; prints
/// `bytes heap_peak rss_before_kib rss_peak_kib`.
fn memory_child(lines: usize) {
    let text = cam_file(lines);
    let (profile, offsets) = machine("default");
    // From here on the peak resident set is the import's (with the text).
    let reset = std::fs::write("/proc/self/clear_refs", "5").is_ok();
    let before = support::resident_kib().map_or(0, |r| r.0);
    let heap_before = LIVE.load(Ordering::Relaxed);
    PEAK.store(heap_before, Ordering::Relaxed);
    let result = import(&text, "bench.nc", &profile, &offsets, Target::Isel);
    let heap_peak = PEAK.load(Ordering::Relaxed) - heap_before;
    let ok = result.is_ok();
    // The peak lasts while the result lives: the editor holds it.
    let rss_peak = support::resident_kib().map_or(0, |r| r.1);
    drop(black_box(result));
    println!(
        "{} {} {} {} {} {}",
        text.len(),
        heap_peak,
        before,
        rss_peak,
        u8::from(reset),
        u8::from(ok)
    );
}

fn memory_row(lines: usize) {
    let exe = std::env::current_exe().expect("the bench's own path");
    let out = Command::new(exe)
        .args(["--memory-child", &lines.to_string()])
        .output();
    let Ok(out) = out else {
        println!("| {lines} | (child failed to start) | | | |");
        return;
    };
    let text = String::from_utf8_lossy(&out.stdout);
    let v: Vec<u64> = text
        .split_whitespace()
        .filter_map(|s| s.parse().ok())
        .collect();
    let [bytes, heap, before, peak, reset, ok] = v[..] else {
        println!(
            "| {lines} | child said: {} {} | | | |",
            text.trim(),
            String::from_utf8_lossy(&out.stderr).trim()
        );
        return;
    };
    println!(
        "| {lines} | {:.1} | {:.1} | {:.1} | {:.1}{} | {:.0} |{}",
        bytes as f64 / MIB,
        heap as f64 / MIB,
        before as f64 / 1024.0,
        peak as f64 / 1024.0,
        if reset == 1 { "" } else { " (not reset)" },
        heap as f64 / lines as f64,
        if ok == 1 { "" } else { " import failed" },
    );
}

/// Wall and CPU time of one run.
type Times = (Duration, Duration);

/// The CNCjs row: `gcode-toolpath` in Node on the same file, best of
/// `runs` in one process. `None` with the reason when it cannot run.
fn cncjs(file: &Path, runs: usize) -> Result<(Times, Times, String), String> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/gcode-bench-node");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let node_version = Command::new("node")
        .arg("--version")
        .output()
        .map_err(|e| format!("no node ({e})"))?;
    let node_version = String::from_utf8_lossy(&node_version.stdout)
        .trim()
        .to_owned();
    let package = dir.join("node_modules/gcode-toolpath/package.json");
    if !package.exists() {
        eprintln!("installing gcode-toolpath into {} …", dir.display());
        let status = Command::new("npm")
            .args([
                "install",
                "--no-audit",
                "--no-fund",
                "--no-save",
                "--prefix",
            ])
            .arg(&dir)
            .arg("gcode-toolpath")
            .status()
            .map_err(|e| format!("no npm ({e})"))?;
        if !status.success() || !package.exists() {
            return Err(format!("`npm install gcode-toolpath` failed ({status})"));
        }
    }
    let version = std::fs::read_to_string(&package)
        .ok()
        .and_then(|p| {
            let v: serde_json::Value = serde_json::from_str(&p).ok()?;
            v.get("version")?.as_str().map(str::to_owned)
        })
        .unwrap_or_else(|| "?".into());
    let script = dir.join("bench.js");
    std::fs::write(
        &script,
        r#"// Written by benches/gcode.rs at every run.
const fs = require('fs');
const Toolpath = require('gcode-toolpath');
const [file, runs] = [process.argv[2], Number(process.argv[3])];
const text = fs.readFileSync(file, 'utf8');
const times = [];
let lines = 0, arcs = 0;
for (let k = 0; k < runs; k++) {
  lines = 0; arcs = 0;
  const c0 = process.cpuUsage();
  const t0 = process.hrtime.bigint();
  const toolpath = new Toolpath({
    addLine: (modal, v1, v2) => { lines++; },
    addArcCurve: (modal, v1, v2, v0) => { arcs++; },
  });
  toolpath.loadFromStringSync(text);
  const wall = Number(process.hrtime.bigint() - t0) / 1e9;
  const c = process.cpuUsage(c0);
  times.push([wall, (c.user + c.system) / 1e6]);
}
console.log(JSON.stringify({
  best: [Math.min(...times.map(t => t[0])), Math.min(...times.map(t => t[1]))],
  first: times[0], lines, arcs,
}));
"#,
    )
    .map_err(|e| format!("{}: {e}", script.display()))?;
    let out = Command::new("node")
        // The file's parsed lines all live at once: the default heap is too small.
        .arg("--max-old-space-size=4096")
        .arg(&script)
        .arg(file)
        .arg(runs.to_string())
        .current_dir(&dir)
        .output()
        .map_err(|e| format!("node: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "node failed: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).map_err(|e| format!("node printed no result ({e})"))?;
    let times = |k: &str| -> Option<Times> {
        let t = v.get(k)?;
        let s = |i: usize| t.get(i).and_then(serde_json::Value::as_f64);
        Some((
            Duration::from_secs_f64(s(0)?),
            Duration::from_secs_f64(s(1)?),
        ))
    };
    let (Some(best), Some(first)) = (times("best"), times("first")) else {
        return Err("node printed no time".into());
    };
    Ok((
        best,
        first,
        format!(
            "gcode-toolpath {version}, node {node_version}: {} lines, {} arcs",
            v.get("lines").unwrap_or(&serde_json::Value::Null),
            v.get("arcs").unwrap_or(&serde_json::Value::Null)
        ),
    ))
}

/// `--profile STAGE`: only that stage, `runs` times, for a profiler
/// (`perf record`, `valgrind --tool=callgrind` with `--lines 20000`).
fn profile_stage(stage: &str, text: &str, profile: &Profile, offsets: &WorkOffsets, runs: usize) {
    let setup = setup_of(profile, offsets).expect("setup");
    let machine_ = machine_of(profile, jogterm::gcode::Target::Isel);
    let toolpath = || interpret(text, &setup).expect("the bench file interprets");
    let header = Header {
        file: "bench.nc".into(),
        profile: profile.name.clone(),
        system: System::G54.to_string(),
        zero: Default::default(),
    };
    let path = (!matches!(stage, "read" | "interpret" | "import")).then(toolpath);
    let start = Instant::now();
    for _ in 0..runs {
        match (stage, &path) {
            ("read", _) => drop(black_box(reader::read(text))),
            ("interpret", _) => drop(black_box(interpret(text, &setup))),
            ("check", Some(p)) => {
                drop(black_box(check_limits(p, &machine_)));
                black_box(summarise(p, &machine_));
            }
            ("isel", Some(p)) => drop(black_box(isel::convert(p, profile, &header))),
            ("import", _) => drop(black_box(import(
                text,
                "bench.nc",
                profile,
                offsets,
                Target::Isel,
            ))),
            _ => panic!("--profile read|interpret|check|isel|import"),
        }
    }
    eprintln!("{stage}: {runs} runs in {:?}", start.elapsed());
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|l| l.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "?".into())
}

fn main() {
    if let Some(n) = arg("--memory-child") {
        memory_child(n.parse().expect("--memory-child LINES"));
        return;
    }
    let lines: usize = arg("--lines").map_or(500_000, |n| n.parse().expect("--lines N"));
    let runs: usize = arg("--runs").map_or(5, |n| n.parse().expect("--runs N"));
    let text = cam_file(lines);
    if let Some(path) = arg("--write") {
        std::fs::write(&path, &text).expect("--write FILE");
        eprintln!(
            "{path}: {} lines, {} bytes; G54 zero at machine {ZERO_MM:?} mm",
            text.lines().count(),
            text.len()
        );
        return;
    }
    let (profile, offsets) = machine("default");
    if let Some(stage) = arg("--profile") {
        profile_stage(&stage, &text, &profile, &offsets, runs);
        return;
    }
    let (emcu_profile, emcu_offsets) = machine("emcu");
    let count = reader::read(&text).lines as usize;
    let bytes = text.len() as f64;
    println!(
        "file: {count} lines, {:.1} MB ({:.1} bytes a line); load average {}",
        bytes / 1e6,
        bytes / count as f64,
        load_average()
    );
    println!();
    println!(
        "| stage (best of {runs}) | wall ms | CPU ms | lines/s (CPU) | MB/s (CPU) | what came out |"
    );
    println!("| --- | ---: | ---: | ---: | ---: | --- |");
    let row = |what: &str, wall: Duration, cpu: Duration, out: String| {
        let s = cpu.as_secs_f64();
        println!(
            "| {what} | {:.1} | {:.1} | {:.2} M | {:.0} | {out} |",
            wall.as_secs_f64() * 1e3,
            s * 1e3,
            count as f64 / s / 1e6,
            bytes / s / 1e6
        );
    };

    let read = best(runs, || reader::read(&text));
    row(
        "read (`reader::read`)",
        read.wall,
        read.cpu,
        format!(
            "{} blocks, {} errors",
            read.out.blocks.len(),
            read.out.errors.len()
        ),
    );
    let (t_read, c_read) = (read.wall, read.cpu);
    drop(read);

    let setup = setup_of(&profile, &offsets).expect("setup");
    let interp = best(runs, || interpret(&text, &setup));
    let toolpath = match &interp.out {
        Ok(t) => t,
        Err(e) => panic!(
            "the bench file does not interpret: {:?}",
            &e[..e.len().min(5)]
        ),
    };
    row(
        "read + interpret (`interpret`)",
        interp.wall,
        interp.cpu,
        format!(
            "{} ops, {} warnings",
            toolpath.ops.len(),
            toolpath.warnings.len()
        ),
    );
    println!(
        "| … interpret alone (the difference) | {:.1} | {:.1} | | | |",
        interp.wall.saturating_sub(t_read).as_secs_f64() * 1e3,
        interp.cpu.saturating_sub(c_read).as_secs_f64() * 1e3
    );

    let machine_ = machine_of(&profile, jogterm::gcode::Target::Isel);
    let check = best(runs, || {
        check_limits(toolpath, &machine_).map(|()| summarise(toolpath, &machine_))
    });
    let summary = check
        .out
        .clone()
        .unwrap_or_else(|e| panic!("outside the soft limits: {e:?}"));
    row(
        "check + summary",
        check.wall,
        check.cpu,
        format!(
            "{} moves, {} arcs, {:.0} m, {:.0} min",
            summary.moves,
            summary.arcs,
            summary.length_mm / 1e3,
            summary.estimated_s / 60.0
        ),
    );

    let header = Header {
        file: "bench.nc".into(),
        profile: profile.name.clone(),
        system: summary.system.to_string(),
        zero: summary.zero,
    };
    let isel_ = best(runs, || isel::convert(toolpath, &profile, &header));
    let commands = match &isel_.out {
        Ok(p) => p.commands,
        Err(e) => panic!("isel: {:?}", &e[..e.len().min(5)]),
    };
    row(
        "convert to isel",
        isel_.wall,
        isel_.cpu,
        format!("{commands} commands"),
    );
    drop(isel_);
    drop(interp);

    let import_isel = best(runs, || {
        import(&text, "bench.nc", &profile, &offsets, Target::Isel)
    });
    let result = match &import_isel.out {
        Ok(r) => r,
        Err(e) => panic!("import: {:?}", &e[..e.len().min(5)]),
    };
    row(
        "**total: `import` to isel**",
        import_isel.wall,
        import_isel.cpu,
        format!(
            "{} output lines, {} warnings, text {:016x}",
            result.program.lines.len(),
            result.warnings.len(),
            fnv(&result.program.text("bench.nc"))
        ),
    );
    let (t_import, c_import) = (import_isel.wall, import_isel.cpu);
    drop(import_isel);

    // The EMCU profile (200 steps/mm, outputs A1 A2): its own toolpath.
    let emcu_setup = setup_of(&emcu_profile, &emcu_offsets).expect("setup");
    let emcu_path = interpret(&text, &emcu_setup)
        .unwrap_or_else(|e| panic!("emcu profile: {:?}", &e[..e.len().min(5)]));
    let emcu_summary = summarise(
        &emcu_path,
        &machine_of(&emcu_profile, jogterm::gcode::Target::Emcu),
    );
    let emcu_header = Header {
        file: "bench.nc".into(),
        profile: emcu_profile.name.clone(),
        system: emcu_summary.system.to_string(),
        zero: emcu_summary.zero,
    };
    let emcu_ = best(runs, || {
        emcu::convert(&emcu_path, &emcu_profile, &emcu_header)
    });
    let commands = match &emcu_.out {
        Ok(p) => p.commands,
        Err(e) => panic!("emcu: {:?}", &e[..e.len().min(5)]),
    };
    row(
        "convert to EMCU (emcu profile)",
        emcu_.wall,
        emcu_.cpu,
        format!("{commands} commands"),
    );
    drop(emcu_);
    drop(emcu_path);
    let import_emcu = best(runs, || {
        import(
            &text,
            "bench.nc",
            &emcu_profile,
            &emcu_offsets,
            Target::Emcu,
        )
    });
    let (lines_out, hash) = match &import_emcu.out {
        Ok(r) => (r.program.lines.len(), fnv(&r.program.text("bench.nc"))),
        Err(e) => panic!("import emcu: {:?}", &e[..e.len().min(5)]),
    };
    row(
        "**total: `import` to EMCU**",
        import_emcu.wall,
        import_emcu.cpu,
        format!("{lines_out} output lines, text {hash:016x}"),
    );
    drop(import_emcu);

    let node_file = std::env::temp_dir().join(format!("jogterm-gbench-{}.nc", std::process::id()));
    if flag("--no-node") {
        println!("| CNCjs gcode-toolpath | skipped (--no-node) | | | |");
    } else if let Err(e) = std::fs::write(&node_file, &text) {
        println!("| CNCjs gcode-toolpath | skipped: {e} | | | |");
    } else {
        match cncjs(&node_file, runs) {
            Ok((best, first, what)) => {
                // Node's CPU time is the process': its garbage collector
                // runs on helper threads too.
                row("CNCjs `loadFromStringSync` (Node)", best.0, best.1, what);
                println!(
                    "| … its first run (cold JIT) | {:.1} | {:.1} | | | |",
                    first.0.as_secs_f64() * 1e3,
                    first.1.as_secs_f64() * 1e3
                );
                println!();
                println!(
                    "ratio jogterm `import` to isel / CNCjs: wall {:.3}, CPU {:.3} (issue 41 item 7: at most 0.10); load average {}",
                    t_import.as_secs_f64() / best.0.as_secs_f64(),
                    c_import.as_secs_f64() / best.1.as_secs_f64(),
                    load_average()
                );
            }
            Err(why) => println!("| CNCjs gcode-toolpath | skipped: {why} | | | |"),
        }
        let _ = std::fs::remove_file(&node_file);
    }

    println!();
    println!("peak memory of one `import` to isel, each size in a fresh process:");
    println!();
    println!(
        "| lines | file MiB | heap peak MiB | RSS before MiB | RSS peak MiB | heap bytes a line |"
    );
    println!("| ---: | ---: | ---: | ---: | ---: | ---: |");
    for n in [lines / 5, lines / 2, lines] {
        memory_row(n);
    }
}

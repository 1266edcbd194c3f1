//! The CAM file of `cargo bench --bench gcode` (docs/gcode.md,
//! "Performance"), generated with a fixed seed, the machine it is imported
//! for and the hash of a converted program's text: shared by the bench and
//! by the golden test of the import (`tests/offline/gcode_golden.rs`,
//! which includes this file by path), so both see the same file.

use std::fmt::Write as _;

use jogterm::axis::Axis;
use jogterm::config::{ConfigDirs, Profile, load_profile};
use jogterm::offsets::{System, WorkOffsets};

/// G54's zero in machine mm: the part's work coordinates sit inside the
/// default profile's soft limits around it.
pub const ZERO_MM: [f64; 3] = [150.0, 100.0, 50.0];

/// Work-coordinate bounds of the generated toolpath (arcs' bulges included).
const X_SPAN: f64 = 120.0;
const Y_SPAN: f64 = 80.0;
const SAFE_Z: f64 = 15.0;

/// A fixed-seed generator (xorshift64*): the same file on every run and
/// every machine.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }

    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// True with probability `p`.
    fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }
}

/// Writes the lines of a CAM file, each spelt in one of the styles posts
/// use, and keeps count.
struct Writer {
    out: String,
    lines: usize,
    n: u32,
    rng: Rng,
    /// Where the tool is, work mm.
    at: (f64, f64, f64),
}

impl Writer {
    /// One block of `words` (e.g. `["G1", "X1.234", "Y5.678"]`): most lines
    /// as Fusion writes them (upper case, blanks), some with an `N` number,
    /// some lower case without blanks, a few with a `;` comment after.
    fn block(&mut self, words: &[String]) {
        let style = self.rng.next() % 100;
        if style < 70 {
            self.n += 5;
            let _ = write!(self.out, "N{} ", self.n);
        }
        if (70..80).contains(&style) {
            for w in words {
                self.out.push_str(&w.to_ascii_lowercase());
            }
        } else {
            self.out.push_str(&words.join(" "));
        }
        if style == 99 {
            self.out.push_str(" ; from the CAM post");
        }
        self.out.push('\n');
        self.lines += 1;
    }

    fn comment(&mut self, text: &str) {
        let _ = writeln!(self.out, "({text})");
        self.lines += 1;
    }

    fn raw(&mut self, line: &str) {
        self.out.push_str(line);
        self.out.push('\n');
        self.lines += 1;
    }

    fn rapid_to(&mut self, x: f64, y: f64) {
        self.block(&["G0".into(), format!("X{x:.4}"), format!("Y{y:.4}")]);
        self.at.0 = x;
        self.at.1 = y;
    }

    fn z(&mut self, motion: &str, z: f64, feed: Option<f64>) {
        let mut words = vec![motion.to_owned(), format!("Z{z:.4}")];
        if let Some(f) = feed {
            words.push(format!("F{f:.0}"));
        }
        self.block(&words);
        self.at.2 = z;
    }
}

/// Rounds to the 4 decimals the file spells.
fn r4(v: f64) -> f64 {
    (v * 10_000.0).round() / 10_000.0
}

/// A 2D contour at `depth`: short `G1` segments (modal, axis words alone)
/// and arcs, I J or R, some tiny, all inside the bounds.
fn contour(w: &mut Writer, depth: f64, budget: usize) {
    let (x0, y0) = (
        r4(w.rng.range(-X_SPAN + 10.0, X_SPAN - 10.0)),
        r4(w.rng.range(-Y_SPAN + 10.0, Y_SPAN - 10.0)),
    );
    w.z("G0", SAFE_Z, None);
    w.rapid_to(x0, y0);
    w.z("G0", 5.0, None);
    w.z("G1", 1.0, Some(1000.0));
    if w.rng.chance(0.3) {
        // A helical ramp: one full turn down to the depth (I J only).
        let r = 2.0;
        w.block(&[
            "G3".into(),
            format!("X{x0:.4}"),
            format!("Y{y0:.4}"),
            format!("Z{depth:.4}"),
            format!("I{r:.4}"),
            "J0.".into(),
            "F400".into(),
        ]);
        w.at.2 = depth;
    } else {
        w.z("G1", depth, Some(300.0));
    }
    let mut heading = w.rng.range(0.0, std::f64::consts::TAU);
    let mut modal_g1 = false;
    let start = w.lines;
    while w.lines - start < budget {
        let (x, y, _) = w.at;
        // Turn back towards the middle near the bounds.
        if x.abs() > X_SPAN - 6.0 || y.abs() > Y_SPAN - 6.0 {
            heading = (-y).atan2(-x) + w.rng.range(-0.5, 0.5);
        }
        let kind = w.rng.next() % 100;
        if kind < 78 {
            // Short straight segment, as CAM writes a spline or an adaptive path.
            heading += w.rng.range(-0.35, 0.35);
            let len = w.rng.range(0.05, 1.5);
            let (nx, ny) = (r4(x + len * heading.cos()), r4(y + len * heading.sin()));
            let mut words = Vec::with_capacity(4);
            if !modal_g1 || w.rng.chance(0.1) {
                words.push("G1".to_owned());
                modal_g1 = true;
            }
            words.push(format!("X{nx:.4}"));
            words.push(format!("Y{ny:.4}"));
            if w.rng.chance(0.03) {
                words.push(format!("F{:.0}", w.rng.range(600.0, 1500.0)));
            }
            w.block(&words);
            w.at.0 = nx;
            w.at.1 = ny;
        } else {
            // An arc turning left or right of the heading, at most 120°.
            let tiny = kind >= 96;
            let r = if tiny {
                w.rng.range(0.02, 0.1)
            } else {
                w.rng.range(0.5, 5.0)
            };
            let ccw = w.rng.chance(0.5);
            let side = if ccw { 1.0 } else { -1.0 };
            let normal = heading + side * std::f64::consts::FRAC_PI_2;
            let (cx, cy) = (x + r * normal.cos(), y + r * normal.sin());
            let sweep = w.rng.range(0.2, 2.0);
            let start_angle = (y - cy).atan2(x - cx);
            let end_angle = start_angle + side * sweep;
            let (ex, ey) = (r4(cx + r * end_angle.cos()), r4(cy + r * end_angle.sin()));
            let g = if ccw { "G3" } else { "G2" };
            let mut words = vec![g.to_owned(), format!("X{ex:.4}"), format!("Y{ey:.4}")];
            if !tiny && w.rng.chance(0.25) {
                words.push(format!("R{r:.4}"));
            } else {
                words.push(format!("I{:.4}", cx - x));
                words.push(format!("J{:.4}", cy - y));
            }
            w.block(&words);
            modal_g1 = false;
            heading += side * sweep;
            w.at.0 = ex;
            w.at.1 = ey;
        }
    }
    w.z("G0", SAFE_Z, None);
}

/// A 3D finishing pass (parallel, as a ball mill follows a surface): X Y Z
/// on every line, the Z from a smooth surface.
fn finishing(w: &mut Writer, budget: usize) {
    let surface = |x: f64, y: f64| -5.0 + 3.0 * (x / 17.0).sin() * (y / 23.0).cos();
    let y0 = r4(w.rng.range(-Y_SPAN + 5.0, Y_SPAN - 5.0));
    let mut x = r4(w.rng.range(-X_SPAN + 5.0, -X_SPAN + 30.0));
    w.z("G0", SAFE_Z, None);
    w.rapid_to(x, y0);
    w.z("G1", r4(surface(x, y0)), Some(800.0));
    w.raw("G1");
    let mut y = y0;
    let mut dir = 1.0;
    for _ in 0..budget {
        x += dir * w.rng.range(0.1, 0.6);
        if x.abs() > X_SPAN - 5.0 {
            dir = -dir;
            y = (y + 0.4).min(Y_SPAN - 5.0);
        }
        // A scallop path follows the surface: it wavers across the pass.
        let (nx, ny) = (r4(x), r4(y + 0.05 * (x / 3.0).sin()));
        let nz = r4(surface(nx, ny));
        w.block(&[
            format!("X{nx:.4}"),
            format!("Y{ny:.4}"),
            format!("Z{nz:.4}"),
        ]);
        w.at = (nx, ny, nz);
    }
    w.z("G0", SAFE_Z, None);
}

/// A drilling operation: G81/G83 cycles over a few holes, then G80.
fn drilling(w: &mut Writer) {
    w.comment("Drill1");
    w.z("G0", SAFE_Z, None);
    let peck = w.rng.chance(0.5);
    for k in 0..6 {
        let x = r4(w.rng.range(-X_SPAN + 10.0, X_SPAN - 10.0));
        let y = r4(w.rng.range(-Y_SPAN + 10.0, Y_SPAN - 10.0));
        let mut words = Vec::new();
        if k == 0 {
            words.push("G98".to_owned());
            words.push(if peck { "G83" } else { "G81" }.to_owned());
        }
        words.push(format!("X{x:.4}"));
        words.push(format!("Y{y:.4}"));
        if k == 0 {
            words.push("Z-6.".into());
            words.push("R5.".into());
            if peck {
                words.push("Q2.".into());
            }
            words.push("F250".into());
        }
        w.block(&words);
        w.at = (x, y, SAFE_Z);
    }
    w.raw("G80");
}

/// The whole file, about `lines` lines.
pub fn cam_file(lines: usize) -> String {
    let mut w = Writer {
        out: String::with_capacity(lines * 34),
        lines: 0,
        n: 0,
        rng: Rng(0x9e37_79b9_7f4a_7c15),
        at: (0.0, 0.0, 0.0),
    };
    for l in [
        "%",
        "(1001)",
        "(Machine)",
        "(  vendor: Autodesk)",
        "(  description: Generic 3-axis)",
        "(T1  D=6. CR=0. - ZMIN=-10. - flat end mill)",
        "G90 G94",
        "G17",
        "G21",
        "",
        "(2D Contour1)",
        "T1 M6",
        "S12000 M3",
        "G54",
    ] {
        w.raw(l);
    }
    let trailer = 6;
    let mut op = 0usize;
    while w.lines + trailer < lines {
        let left = lines - trailer - w.lines;
        op += 1;
        w.comment(&format!("Operation {op}"));
        // Big CAM files are mostly 3D finishing: every other operation.
        match op % 8 {
            1 | 3 | 5 => finishing(&mut w, left.min(3000)),
            7 => drilling(&mut w),
            _ => {
                let depth = -w.rng.range(0.5, 10.0);
                contour(&mut w, r4(depth), left.min(2000));
            }
        }
        if op.is_multiple_of(40) {
            w.raw("M5");
            w.comment("T2 D=3. CR=0. - flat end mill");
            w.raw("T2 M6");
            w.raw("S15000 M3");
        }
    }
    w.z("G0", SAFE_Z, None);
    w.raw("M5");
    w.raw("G28 G91 Z0.");
    w.raw("G90");
    w.raw("M30");
    w.raw("%");
    w.out
}

/// A built-in profile (`default`: isel, `emcu`) with G28 ignored (Fusion's
/// grbl post ends with `G28 G91 Z0.`), and the work offsets that put the
/// part inside its limits (the same for both: their soft limits are).
pub fn machine(name: &str) -> (Profile, WorkOffsets) {
    let mut profile = load_profile(name, &ConfigDirs::builtin_only())
        .unwrap_or_else(|e| panic!("{name} profile: {e}"));
    profile.gcode.codes.insert("g28".into(), "ignore".into());
    if name == "emcu" {
        // The EMCU profile gives no output the spindle role: the spindle
        // relay on A1, as its [gcode] table would say.
        for m in ["m3", "m5"] {
            profile.gcode.codes.insert(m.into(), "output:A1".into());
        }
    }
    let mut offsets = WorkOffsets::default();
    for (axis, mm) in [Axis::X, Axis::Y, Axis::Z].into_iter().zip(ZERO_MM) {
        let p = profile.axis(axis).expect("axis");
        offsets.set(System::G54, axis, (mm * p.steps_per_unit).round() as i64);
    }
    (profile, offsets)
}

/// FNV-1a of a converted program's text: the same file must convert to
/// the same program before and after an optimisation.
pub fn fnv(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}
